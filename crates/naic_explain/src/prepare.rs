//! From a raw time series to the analysis samples.
//!
//! Velocity and acceleration are estimated from the joint positions by a
//! **Savitzky–Golay** filter (local cubic least-squares fit over a centred window,
//! default 51 ms; its first and second derivatives at the window centre). The
//! measured torque is smoothed by the same filter, so torque and motion carry the
//! same (zero) phase and the same bandwidth. The measured `dq` column is not used
//! (drive velocities are often filtered with an unknown lag).
//!
//! The filter is evaluated only at the analysis instants: every `stride`-th sample,
//! chosen so the analysis runs at ≈ 100 Hz and on at most `max_samples` instants
//! (longer recordings are analysed at a lower rate; the filter still uses every raw
//! sample in its window).
//!
//! Each analysis sample gets, per joint, a *regime*: +1 / −1 when the joint moves
//! faster than `v_rest` in that direction, 0 at rest. Samples whose neighbourhood
//! (± half a filter window plus one analysis step) contains a regime change are
//! marked `keep = false`: there the friction sign flips inside the filter window and
//! neither the smoothed torque nor any static friction law is meaningful.
//!
//! Then the rigid-body torque `τ_rb = RNEA(q, q̇, q̈)` of the URDF (any serial arm), the gravity
//! torque, the tool-mass regressor `J_tipᵀ (p̈_tip − g)` and the torque rate `τ̇` are
//! computed per sample.

use crate::input::{Rows, TimeSeries};
use crate::ExplainError;
use nalgebra::{DMatrix, DVector, Vector3};
use naic_core::dynamics::{frame_jacobian, frame_jdot_qdot, gravity_torques, rnea};
use naic_core::model::{Data, FrameId, Model};

/// Settings of the estimation step.
#[derive(Clone, Debug)]
pub struct PrepareOptions {
    /// Savitzky–Golay window length [s] (odd number of samples around it).
    pub window_s: f64,
    /// Polynomial order of the Savitzky–Golay fit.
    pub order: usize,
    /// Target analysis rate [Hz].
    pub rate_hz: f64,
    /// At most this many analysis instants (the rate is lowered for long files).
    pub max_samples: usize,
    /// |q̇| below this is rest [rad/s].
    pub v_rest: f64,
}

impl Default for PrepareOptions {
    fn default() -> Self {
        Self { window_s: 0.051, order: 5, rate_hz: 100.0, max_samples: 60_000, v_rest: 1e-3 }
    }
}

/// Savitzky–Golay coefficients for the value and first two derivatives at the centre
/// of a window of `2h+1` samples spaced `dt`, for a polynomial of `order`.
pub fn savgol_coefficients(h: usize, order: usize, dt: f64) -> [Vec<f64>; 3] {
    let m = 2 * h + 1;
    let p = order + 1;
    let mut a = DMatrix::zeros(m, p);
    for r in 0..m {
        let x = r as f64 - h as f64;
        let mut xp = 1.0;
        for c in 0..p {
            a[(r, c)] = xp;
            xp *= x;
        }
    }
    // pinv = (AᵀA)⁻¹Aᵀ; row k gives the k-th polynomial coefficient.
    let ata = a.tr_mul(&a);
    let inv = ata.try_inverse().unwrap_or_else(|| DMatrix::identity(p, p));
    let pinv = inv * a.transpose();
    let row = |k: usize, scale: f64| -> Vec<f64> {
        if k >= p {
            return vec![0.0; m];
        }
        (0..m).map(|r| pinv[(k, r)] * scale).collect()
    };
    [row(0, 1.0), row(1, 1.0 / dt), row(2, 2.0 / (dt * dt))]
}

/// The analysis samples (struct of arrays; index `[i][j]` = sample i, joint j).
#[derive(Clone, Debug, Default)]
pub struct Prepared {
    pub t: Vec<f64>,
    pub q: Rows,
    pub v: Rows,
    pub a: Rows,
    /// Smoothed measured torque.
    pub tau: Rows,
    /// Time derivative of the smoothed measured torque.
    pub dtau: Rows,
    /// Rigid-body torque RNEA(q, v, a).
    pub tau_rb: Rows,
    /// Gravity torque G(q).
    pub grav: Rows,
    /// Torque per kg of a point mass at the `tip` frame: J_tip,linᵀ (p̈_tip − g).
    pub payload: Rows,
    pub regime: Vec<Vec<i8>>,
    pub keep: Vec<Vec<bool>>,
    /// Raw sample index of each analysis instant.
    pub raw_index: Vec<usize>,
    /// Measured wrench smoothed by the same filter (empty without wrench data).
    pub wrench: Vec<[f64; 6]>,
    /// Raw sample period and analysis stride.
    pub dt_raw: f64,
    pub stride: usize,
    pub raw_samples: usize,
    pub window_samples: usize,
}

impl Prepared {
    pub fn len(&self) -> usize {
        self.t.len()
    }
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }
    /// Analysis sample period [s].
    pub fn dt(&self) -> f64 {
        self.dt_raw * self.stride as f64
    }
    /// Number of joints.
    pub fn nj(&self) -> usize {
        self.q.width()
    }
    /// Appends the analysis instants of another segment (same model and filter). Its
    /// times are shifted to start one analysis step after this one's last instant when
    /// they would overlap (separate runs each starting at t = 0).
    pub fn append(&mut self, o: Prepared) {
        if self.is_empty() {
            *self = o;
            return;
        }
        let last = self.t.last().copied().unwrap_or(0.0);
        let first = o.t.first().copied().unwrap_or(0.0);
        let shift = if first <= last { last + self.dt() - first } else { 0.0 };
        self.t.extend(o.t.iter().map(|t| t + shift));
        let base = self.raw_samples;
        self.raw_index.extend(o.raw_index.iter().map(|i| i + base));
        for (a, b) in [
            (&mut self.q, &o.q),
            (&mut self.v, &o.v),
            (&mut self.a, &o.a),
            (&mut self.tau, &o.tau),
            (&mut self.dtau, &o.dtau),
            (&mut self.tau_rb, &o.tau_rb),
            (&mut self.grav, &o.grav),
            (&mut self.payload, &o.payload),
        ] {
            a.extend(b);
        }
        self.regime.extend(o.regime);
        self.keep.extend(o.keep);
        self.wrench.extend(o.wrench);
        self.raw_samples += o.raw_samples;
    }
}

/// Estimates velocity/acceleration and computes the model quantities (see module docs).
/// `progress(fraction)` is called now and then.
pub fn prepare(
    ts: &TimeSeries,
    model: &Model,
    tip: FrameId,
    opts: &PrepareOptions,
    progress: &mut dyn FnMut(f64),
) -> Result<Prepared, ExplainError> {
    let n = ts.len();
    let dt = ts.dt();
    let mut h = ((opts.window_s / dt) / 2.0).round() as usize;
    h = h.max(opts.order.div_ceil(2) + 1);
    if 2 * h + 1 >= n {
        return Err(ExplainError::input(format!(
            "only {n} samples at dt = {dt} s; the {} s filter window needs far more (record longer)",
            opts.window_s
        )));
    }
    let mut stride = ((1.0 / opts.rate_hz) / dt).round().max(1.0) as usize;
    let usable = n - 2 * h;
    if usable / stride > opts.max_samples {
        stride = usable.div_ceil(opts.max_samples);
    }
    let [c0, c1, c2] = savgol_coefficients(h, opts.order, dt);
    let idx: Vec<usize> = (h..n - h).step_by(stride).collect();
    let m = idx.len();
    let mut p = Prepared {
        dt_raw: dt,
        stride,
        raw_samples: n,
        window_samples: 2 * h + 1,
        ..Default::default()
    };
    p.t.reserve(m);
    let nj = model.nv();
    if ts.nj() != nj {
        return Err(ExplainError::input(format!("the data has {} joints, the robot model {nj}", ts.nj())));
    }
    for r in [&mut p.q, &mut p.v, &mut p.a, &mut p.tau, &mut p.dtau, &mut p.tau_rb, &mut p.grav, &mut p.payload] {
        *r = Rows::with_capacity(nj, m);
    }
    let mut data = Data::new(model);
    let g = Vector3::new(0.0, 0.0, -9.81);
    let (mut qv, mut vv, mut av) = (DVector::zeros(nj), DVector::zeros(nj), DVector::zeros(nj));
    let (mut tau, mut dtau, mut pl) = (vec![0.0; nj], vec![0.0; nj], vec![0.0; nj]);
    for (k, &i) in idx.iter().enumerate() {
        if k % 8192 == 0 {
            progress(k as f64 / m as f64);
        }
        qv.fill(0.0);
        vv.fill(0.0);
        av.fill(0.0);
        tau.fill(0.0);
        dtau.fill(0.0);
        if let Some(wr) = &ts.wrench {
            let mut ws = [0.0; 6];
            for (w, r) in (i - h..=i + h).enumerate() {
                for (x, v) in ws.iter_mut().zip(&wr[r]) {
                    *x += c0[w] * v;
                }
            }
            p.wrench.push(ws);
        }
        for (w, r) in (i - h..=i + h).enumerate() {
            let (w0, w1, w2) = (c0[w], c1[w], c2[w]);
            let qr = &ts.q[r];
            let tr = &ts.tau[r];
            for j in 0..nj {
                qv[j] += w0 * qr[j];
                vv[j] += w1 * qr[j];
                av[j] += w2 * qr[j];
                tau[j] += w0 * tr[j];
                dtau[j] += w1 * tr[j];
            }
        }
        p.tau_rb.push(rnea(model, &mut data, &qv, &vv, &av).as_slice());
        p.grav.push(gravity_torques(model, &mut data, &qv).as_slice());
        let jdqd = frame_jdot_qdot(model, &mut data, &qv, &vv, tip);
        let jdqd_lin = Vector3::new(jdqd[0], jdqd[1], jdqd[2]);
        let jac = frame_jacobian(model, &mut data, &qv, tip);
        let jl = jac.fixed_rows::<3>(0);
        let acc_g = jl * &av + jdqd_lin - g;
        for (j, x) in pl.iter_mut().enumerate() {
            *x = jl.column(j).dot(&acc_g);
        }
        let reg: Vec<i8> = vv
            .iter()
            .map(|&v| {
                if v > opts.v_rest {
                    1
                } else if v < -opts.v_rest {
                    -1
                } else {
                    0
                }
            })
            .collect();
        p.t.push(ts.t[i]);
        p.raw_index.push(i);
        p.q.push(qv.as_slice());
        p.v.push(vv.as_slice());
        p.a.push(av.as_slice());
        p.tau.push(&tau);
        p.dtau.push(&dtau);
        p.payload.push(&pl);
        p.regime.push(reg);
    }
    // Keep mask: constant regime over ± (h/stride + 1) analysis samples.
    let margin = h.div_ceil(stride) + 1;
    p.keep = vec![vec![true; nj]; m];
    for j in 0..nj {
        // last index at which the regime changed, scanning both ways
        let mut change = vec![false; m];
        for k in 1..m {
            change[k] = p.regime[k][j] != p.regime[k - 1][j];
        }
        // prefix count of changes
        let mut pre = vec![0u32; m + 1];
        for k in 0..m {
            pre[k + 1] = pre[k] + change[k] as u32;
        }
        for k in 0..m {
            let lo = k.saturating_sub(margin) + 1;
            let hi = (k + margin).min(m - 1);
            // changes at indices lo..=hi (a change at index x is between x-1 and x)
            if lo <= hi && pre[hi + 1] - pre[lo] > 0 {
                p.keep[k][j] = false;
            }
        }
    }
    progress(1.0);
    Ok(p)
}
