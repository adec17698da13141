//! The samples of one joint (or contact axis) and the regressor column values of each
//! sample ([`JointSamples::col`]): the rows of the design matrix.

use super::{Col, Dir, NominalShape, Structure};
use crate::catalogue::Effect;

/// The `fold` of a sample from a validation run (`--validate`): never trained on, scored
/// with the model fitted on all the other samples ([`Eval::val_ssr`](super::Eval::val_ssr)).
pub const VALIDATION_FOLD: u8 = u8::MAX;

/// The samples of one joint, ready for regression.
#[derive(Clone, Debug, Default)]
pub struct JointSamples {
    /// 1-based joint number.
    pub joint: usize,
    /// Residual to explain: measured torque − rigid-body torque [N·m].
    pub y: Vec<f64>,
    pub v: Vec<f64>,
    /// sgn(q̇) with 0 at rest: tanh(q̇/`coulomb_width`) (the exact sign when the width is 0).
    pub s: Vec<f64>,
    /// Smoothing of the Coulomb law's sgn(q̇) [rad/s] (time series: calibrated per joint by
    /// [`calibrate_coulomb_width`](super::calibrate_coulomb_width); 0 = the exact sign).
    pub coulomb_width: f64,
    pub q: Vec<f64>,
    /// Time [s] (row order for friction points).
    pub t: Vec<f64>,
    /// (t − t_mid)/T ∈ [−0.5, 0.5].
    pub tn: Vec<f64>,
    pub a: Vec<f64>,
    pub dtau: Vec<f64>,
    pub payload: Vec<f64>,
    /// Rigid-body torque of the URDF (time series) [N·m].
    pub tau_rb: Vec<f64>,
    pub fold: Vec<u8>,
    /// Samples per independent observation (filter window / analysis step), ≥ 1.
    pub corr_len: f64,
    /// Time series: the raw sample period [s] (the longest of the runs); 0 for friction points.
    /// A `delay` shorter than it is flagged in the report ([`crate::report::findings`]).
    pub sample_period: f64,
    pub time_series: bool,
    /// A sensor axis of contact data (targets `fx..mz`) rather than a joint.
    pub contact: bool,
    /// Contact: sensor-frame component of the unit contact force (or its moment) on this axis.
    pub cu: Vec<f64>,
    /// Contact: tip height along the surface normal [m].
    pub cz: Vec<f64>,
    /// Contact: penetration rate δ̇ = −ż_tip [m/s].
    pub crate_: Vec<f64>,
    /// Contact: the two tool-gravity regressors of this axis.
    pub cg0: Vec<f64>,
    pub cg1: Vec<f64>,
    /// Contact: grid of surface heights to scan [m] (empty when the axis is not coupled).
    pub h_grid: Vec<f64>,
    /// Contact: the axis sees the contact force (else it has no contact columns).
    pub coupled: bool,
    /// `inertial_parameters`: per sample, `Y_B,j δβ` of the correction fitted without the
    /// sample's fold (empty until the all-joint stage finds it, [`crate::inertial`]).
    pub inertial: Vec<f64>,
    /// `inertial_parameters`: the parameters its one column stands for when the forward
    /// selection chooses among significant candidates (`Candidate::heldout_bic`) — this
    /// joint's share of the r base parameters the joints share, ⌈r / N⌉ (set with `inertial`).
    pub inertial_params: usize,
    /// `delay` (time series): q⃛, and the rate and second rate of the rigid-body torque
    /// (see [`crate::prepare::Prepared::dtau_rb`]).
    pub jerk: Vec<f64>,
    pub dtau_rb: Vec<f64>,
    pub ddtau_rb: Vec<f64>,
    /// `delay` (time series): per sample, the exact shifts of the rigid-body model on the
    /// lattice k·`shift_step`, k = −`shift_half` … `shift_half` (2·`shift_half` + 1 values per
    /// sample; see [`crate::prepare::Prepared::rb_shift`]); empty: the Taylor expansion about t.
    pub rb_shift: Vec<f32>,
    pub shift_step: f64,
    pub shift_half: usize,
}

impl JointSamples {
    /// The target of sample `i` under structure `st`: τ_measured − τ_rb(t − delay) (y itself
    /// without a delay). A delay found by the scan and then fixed on every joint
    /// (`delay_fixed`, [`crate::pipeline::analyse_all`]) uses the lattice of exact shifts:
    /// d = k·Δ + r (k the nearest lattice point), τ_rb(t) − τ_rb(t − k·Δ) exactly, the remainder
    /// r to second order. The scan that detects a delay uses the Taylor expansion about t: on
    /// the independent generator's clean multi-sines the lattice's own steps (a different
    /// encoder-noise realisation at each k) were read as significant sub-sample delays.
    #[inline]
    pub fn target(&self, st: &Structure, i: usize) -> f64 {
        let d = st.delay;
        if d == 0.0 {
            return self.y[i];
        }
        let ns = 2 * self.shift_half + 1;
        if st.delay_fixed && self.shift_half > 0 && self.rb_shift.len() == ns * self.y.len() {
            let k = (d / self.shift_step).round().clamp(-(self.shift_half as f64), self.shift_half as f64);
            let r = d - k * self.shift_step;
            let exact = f64::from(self.rb_shift[i * ns + (k as isize + self.shift_half as isize) as usize]);
            return self.y[i] + exact + r * self.dtau_rb[i] - 0.5 * r * r * self.ddtau_rb[i];
        }
        self.y[i] + d * self.dtau_rb[i] - 0.5 * d * d * self.ddtau_rb[i]
    }

    pub fn len(&self) -> usize {
        self.y.len()
    }
    pub fn is_empty(&self) -> bool {
        self.y.is_empty()
    }

    #[inline]
    pub(crate) fn col(&self, c: Col, st: &Structure, sh: &NominalShape, i: usize) -> f64 {
        // with a delay d the model is evaluated at the motion of t − d (second order)
        let (s, v, q, a) = if st.delay != 0.0 && self.jerk.len() == self.y.len() {
            let (d, j) = (st.delay, self.jerk[i]);
            let (v0, a0) = (self.v[i], self.a[i]);
            let v = v0 - d * a0 + 0.5 * d * d * j;
            let s = if self.s[i] == 0.0 {
                0.0
            } else if self.coulomb_width > 0.0 {
                (v / self.coulomb_width).tanh()
            } else {
                v.signum()
            };
            (s, v, self.q[i] - d * v0 + 0.5 * d * d * a0, a0 - d * j)
        } else {
            (self.s[i], self.v[i], self.q[i], self.a[i])
        };
        let ind = |d: Dir| match d {
            Dir::Both => 1.0,
            Dir::Pos => (s > 0.0) as u8 as f64,
            Dir::Neg => (s < 0.0) as u8 as f64,
        };
        match c {
            Col::Coul(d) => {
                let shape = if st.has(Effect::Stribeck) || sh.r0 == 0.0 {
                    1.0
                } else {
                    let x = v / sh.q_s0;
                    1.0 + sh.r0 * (-x * x).exp()
                };
                ind(d) * s * shape
            }
            Col::Visc(d) => ind(d) * v,
            Col::Strib(d) => {
                let qs = if d == Dir::Neg { st.q_s_neg } else { st.q_s_pos };
                let x = v / qs;
                ind(d) * s * (-x * x).exp()
            }
            Col::Offset => 1.0,
            Col::RipSin => s * (st.k * q).sin(),
            Col::RipCos => s * (st.k * q).cos(),
            Col::PosSin => (st.k_pos * q).sin(),
            Col::PosCos => (st.k_pos * q).cos(),
            Col::Payload => self.payload[i],
            Col::Drift => s * self.tn[i],
            Col::Rotor => a,
            Col::Visc2(d) => ind(d) * s * v * v,
            Col::Scale => self.tau_rb[i] - self.target(st, i) + self.y[i],
            Col::Inertial => self.inertial[i],
            Col::Spring => {
                let d = st.h - self.cz[i];
                if d > 0.0 {
                    self.cu[i] * if st.n_exp == 1.0 { d } else { d.powf(st.n_exp) }
                } else {
                    0.0
                }
            }
            Col::CDamp => {
                if st.h > self.cz[i] {
                    self.cu[i] * self.crate_[i]
                } else {
                    0.0
                }
            }
            Col::Grav0 => self.cg0[i],
            Col::Grav1 => self.cg1[i],
        }
    }

    /// Appends the samples of `o` (same target).
    pub fn append(&mut self, o: &JointSamples) {
        for (a, b) in [
            (&mut self.y, &o.y),
            (&mut self.v, &o.v),
            (&mut self.s, &o.s),
            (&mut self.q, &o.q),
            (&mut self.t, &o.t),
            (&mut self.tn, &o.tn),
            (&mut self.a, &o.a),
            (&mut self.dtau, &o.dtau),
            (&mut self.payload, &o.payload),
            (&mut self.tau_rb, &o.tau_rb),
            (&mut self.cu, &o.cu),
            (&mut self.cz, &o.cz),
            (&mut self.crate_, &o.crate_),
            (&mut self.cg0, &o.cg0),
            (&mut self.cg1, &o.cg1),
            (&mut self.inertial, &o.inertial),
            (&mut self.jerk, &o.jerk),
            (&mut self.dtau_rb, &o.dtau_rb),
            (&mut self.ddtau_rb, &o.ddtau_rb),
        ] {
            a.extend_from_slice(b);
        }
        if self.shift_step == o.shift_step && self.shift_half == o.shift_half {
            self.rb_shift.extend_from_slice(&o.rb_shift);
        } else {
            // runs analysed with different lattices: the Taylor expansion about t for all
            self.rb_shift.clear();
            self.shift_half = 0;
        }
        self.fold.extend_from_slice(&o.fold);
        self.sample_period = self.sample_period.max(o.sample_period);
    }

    /// Whether sample `i` belongs to a validation run.
    pub fn is_validation(&self, i: usize) -> bool {
        self.fold[i] == VALIDATION_FOLD
    }

    /// The samples with `keep[i]`; friction-point folds are re-interleaved.
    pub fn filtered(&self, keep: &[bool], folds: usize) -> JointSamples {
        let pick = |v: &Vec<f64>| -> Vec<f64> { v.iter().zip(keep).filter(|(_, k)| **k).map(|(x, _)| *x).collect() };
        let mut out = JointSamples {
            joint: self.joint,
            y: pick(&self.y),
            v: pick(&self.v),
            s: pick(&self.s),
            q: pick(&self.q),
            t: pick(&self.t),
            tn: pick(&self.tn),
            a: pick(&self.a),
            dtau: pick(&self.dtau),
            payload: pick(&self.payload),
            tau_rb: pick(&self.tau_rb),
            fold: self.fold.iter().zip(keep).filter(|(_, k)| **k).map(|(x, _)| *x).collect(),
            corr_len: self.corr_len,
            sample_period: self.sample_period,
            coulomb_width: self.coulomb_width,
            time_series: self.time_series,
            contact: self.contact,
            cu: pick(&self.cu),
            cz: pick(&self.cz),
            crate_: pick(&self.crate_),
            cg0: pick(&self.cg0),
            cg1: pick(&self.cg1),
            h_grid: self.h_grid.clone(),
            coupled: self.coupled,
            inertial: pick(&self.inertial),
            inertial_params: self.inertial_params,
            jerk: pick(&self.jerk),
            dtau_rb: pick(&self.dtau_rb),
            ddtau_rb: pick(&self.ddtau_rb),
            rb_shift: if self.rb_shift.len() == self.len() * (2 * self.shift_half + 1) {
                let ns = 2 * self.shift_half + 1;
                self.rb_shift.chunks(ns).zip(keep).filter(|(_, k)| **k).flat_map(|(c, _)| c.iter().copied()).collect()
            } else {
                Vec::new()
            },
            shift_step: self.shift_step,
            shift_half: self.shift_half,
        };
        if !self.time_series {
            out.assign_velocity_folds(folds);
        }
        out
    }

    /// Interleaved velocity folds: per direction, sorted by speed, rank r → fold r mod K.
    pub fn assign_velocity_folds(&mut self, folds: usize) {
        for dir in [-1.0, 0.0, 1.0] {
            let mut idx: Vec<usize> = (0..self.len()).filter(|&i| self.s[i] == dir).collect();
            idx.sort_by(|&a, &b| self.v[a].abs().total_cmp(&self.v[b].abs()));
            for (r, &i) in idx.iter().enumerate() {
                self.fold[i] = (r % folds) as u8;
            }
        }
    }

    /// Whether an effect can apply to these samples.
    pub fn applicable(&self, e: Effect) -> bool {
        let needs_spring = matches!(e, Effect::ContactNonlinearity | Effect::ContactDamping);
        if e == Effect::InertialParameters {
            // only after the all-joint stage found it and set the column (crate::inertial)
            self.time_series && !self.contact && self.inertial.len() == self.len()
        } else if e.is_contact() != self.contact || (needs_spring && !self.coupled) {
            false
        } else if self.time_series {
            e != Effect::Delay || self.dtau_rb.len() == self.len()
        } else {
            e.applies_to_points()
        }
    }
}
