//! Residual analysis: per joint, forward selection of candidate extensions scored on
//! held-out folds.
//!
//! # Held-out scheme
//! * Time series: the recording is cut into blocks of `block_s` seconds (default 2 s,
//!   longer for long files so there are ≤ 400 blocks); block b belongs to fold `b mod K`
//!   (K = 10). Every fold therefore holds ~10 % of the data spread over the whole
//!   session, in contiguous time blocks (not random samples), so correlated noise and
//!   filter smoothing cannot leak from training into test samples.
//! * Friction points: per joint and direction the points are sorted by speed and point
//!   r goes to fold `r mod K` (interleaved velocity blocks): every fold covers the whole
//!   speed range and each held-out point is predicted from its neighbours in speed.
//!
//! Shape parameters (q_s, k) are chosen per fold on that fold's training part (grid
//! scan + local refinement), amplitudes by linear least squares — so held-out numbers
//! contain no information from the held-out samples.
//!
//! # Significance rule (per joint)
//! A candidate that adds Δp parameters to the current model is **significant** when all of:
//! 1. held-out gain `g = 1 − SSR_ho(new)/SSR_ho(current) ≥ min_gain` (default 2 %);
//! 2. it lowers the held-out SSR in at least `min_fold_wins` of the K folds (default 8 of 10);
//! 3. BIC on the whole data improves: `n_eff·ln(SSR_new/SSR_cur) + Δp·ln(n_eff) < 0`, with
//!    `n_eff` = samples / (filter window in analysis samples) for time series (filtered
//!    samples are not independent), = points for friction points.
//!
//! Forward selection: of the significant candidates the one with the lowest held-out BIC
//! (n_eff·ln of the held-out SSR ratio + ln(n_eff) per parameter) is added to the joint's
//! model (where two explain the same residual about equally, the one with fewer
//! parameters), the rest are re-scored against the extended model, until none is
//! significant.

use crate::catalogue::{k_grid, k_pos_grid, n_exp_grid, q_s_grid, Effect};
use nalgebra::{DMatrix, DVector};
use std::collections::BTreeSet;

/// The `fold` of a sample from a validation run (`--validate`): never trained on, scored
/// with the model fitted on all the other samples ([`Eval::val_ssr`]).
pub const VALIDATION_FOLD: u8 = u8::MAX;

/// Direction a friction column applies to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dir {
    Both,
    Pos,
    Neg,
}

/// A regressor column.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Col {
    Coul(Dir),
    Visc(Dir),
    Strib(Dir),
    Offset,
    RipSin,
    RipCos,
    /// `position_torque`: `sin(k' q)`, `cos(k' q)`.
    PosSin,
    PosCos,
    Payload,
    Drift,
    Rotor,
    Visc2,
    /// The rigid-body torque (`torque_scale`).
    Scale,
    /// The joint's share of the cross-fitted base-parameter correction (`inertial_parameters`).
    Inertial,
    /// Contact spring `u·δ₊ⁿ` (n = 1 nominal).
    Spring,
    /// Contact damping `u·δ̇·[δ > 0]`.
    CDamp,
    /// Tool-gravity columns (see [`crate::catalogue`]).
    Grav0,
    Grav1,
}

/// A scanned shape parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScanParam {
    Qs,
    QsPos,
    QsNeg,
    K,
    /// `position_torque` wave number k'.
    KPos,
    /// Surface height h [m] (contact).
    H,
    /// Contact exponent n.
    NExp,
    /// Delay of the torque channel [s] (`delay`: the model is evaluated at the motion of t − delay).
    Delay,
}

/// The nominal Stribeck shape σ₀(q̇) = 1 + r₀·e^{−(q̇/q_s0)²} (from `--nominal`; r₀ = 0 = flat).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NominalShape {
    pub r0: f64,
    pub q_s0: f64,
}

impl Default for NominalShape {
    fn default() -> Self {
        Self { r0: 0.0, q_s0: 0.01 }
    }
}

/// A joint model: the nominal friction plus a set of effects with their shape values.
#[derive(Clone, Debug, PartialEq)]
pub struct Structure {
    pub effects: BTreeSet<Effect>,
    pub q_s_pos: f64,
    pub q_s_neg: f64,
    pub k: f64,
    /// `position_torque` wave number k' [rad⁻¹].
    pub k_pos: f64,
    /// Contact structures: the spring is `u·(h − z)₊ⁿ`.
    pub contact: bool,
    /// Contact: the target sees the contact force (has the spring column).
    pub coupled: bool,
    pub h: f64,
    pub n_exp: f64,
    /// `delay`: the torque channel lags the motion by this [s] (the model is evaluated at the
    /// motion of t − delay, see [`JointSamples::target`] and `col`).
    pub delay: f64,
    /// The delay was found on other joints and is fixed here (no parameter of this joint).
    pub delay_fixed: bool,
}

impl Structure {
    pub fn nominal() -> Self {
        Self {
            effects: BTreeSet::new(),
            q_s_pos: 0.02,
            q_s_neg: 0.02,
            k: 10.0,
            k_pos: 5.0,
            contact: false,
            coupled: false,
            h: 0.0,
            n_exp: 1.0,
            delay: 0.0,
            delay_fixed: false,
        }
    }
    /// The nominal structure of a target and the shape parameters its calibration scans
    /// (joints: none; contact axes: the surface height).
    pub fn nominal_for(js: &JointSamples) -> (Self, Vec<ScanParam>) {
        if js.contact {
            let h = js.h_grid.get(js.h_grid.len() / 2).copied().unwrap_or(0.0);
            let scan = if js.coupled { vec![ScanParam::H] } else { vec![] };
            (Self { contact: true, coupled: js.coupled, h, ..Self::nominal() }, scan)
        } else {
            (Self::nominal(), vec![])
        }
    }
    /// Number of shape (non-linear, scanned) parameters of the structure, for the information criterion.
    pub fn n_shape(&self) -> usize {
        if self.contact {
            return self.coupled as usize * (1 + self.has(Effect::ContactNonlinearity) as usize);
        }
        let strib = if self.has(Effect::Stribeck) { 1 + self.has(Effect::FrictionAsymmetry) as usize } else { 0 };
        strib
            + self.has(Effect::PositionRipple) as usize
            + self.has(Effect::PositionTorque) as usize
            + (self.has(Effect::Delay) && !self.delay_fixed) as usize
    }
    pub fn has(&self, e: Effect) -> bool {
        self.effects.contains(&e)
    }
    pub fn columns(&self) -> Vec<Col> {
        if self.contact {
            let mut c = if self.coupled { vec![Col::Spring] } else { vec![] };
            for e in &self.effects {
                match e {
                    Effect::ContactDamping => c.push(Col::CDamp),
                    Effect::FtBias => c.push(Col::Offset),
                    Effect::ToolGravity => {
                        c.push(Col::Grav0);
                        c.push(Col::Grav1)
                    }
                    _ => {}
                }
            }
            return c;
        }
        let asym = self.has(Effect::FrictionAsymmetry);
        let dirs: &[Dir] = if asym { &[Dir::Pos, Dir::Neg] } else { &[Dir::Both] };
        let mut c = Vec::new();
        for &d in dirs {
            c.push(Col::Coul(d));
            c.push(Col::Visc(d));
            if self.has(Effect::Stribeck) {
                c.push(Col::Strib(d));
            }
        }
        for e in &self.effects {
            match e {
                Effect::TorqueOffset => c.push(Col::Offset),
                Effect::PositionRipple => {
                    c.push(Col::RipSin);
                    c.push(Col::RipCos)
                }
                Effect::Payload => c.push(Col::Payload),
                Effect::Drift => c.push(Col::Drift),
                Effect::RotorInertia => c.push(Col::Rotor),
                Effect::ViscousNonlinearity => c.push(Col::Visc2),
                Effect::TorqueScale => c.push(Col::Scale),
                Effect::PositionTorque => {
                    c.push(Col::PosSin);
                    c.push(Col::PosCos)
                }
                Effect::InertialParameters => c.push(Col::Inertial),
                // no column: it shifts the motion the model is evaluated at (JointSamples::target, col)
                Effect::FrictionAsymmetry | Effect::Stribeck | Effect::Delay => {}
                Effect::ContactNonlinearity | Effect::ContactDamping | Effect::FtBias | Effect::ToolGravity => {}
            }
        }
        c
    }
    fn get(&self, p: ScanParam) -> f64 {
        match p {
            ScanParam::Qs | ScanParam::QsPos => self.q_s_pos,
            ScanParam::QsNeg => self.q_s_neg,
            ScanParam::K => self.k,
            ScanParam::KPos => self.k_pos,
            ScanParam::H => self.h,
            ScanParam::NExp => self.n_exp,
            ScanParam::Delay => self.delay,
        }
    }
    fn set(&mut self, p: ScanParam, v: f64) {
        match p {
            ScanParam::Qs => {
                self.q_s_pos = v;
                self.q_s_neg = v
            }
            ScanParam::QsPos => self.q_s_pos = v,
            ScanParam::QsNeg => self.q_s_neg = v,
            ScanParam::K => self.k = v,
            ScanParam::KPos => self.k_pos = v,
            ScanParam::H => self.h = v,
            ScanParam::NExp => self.n_exp = v,
            ScanParam::Delay => self.delay = v,
        }
    }
    /// The structure with `e` added and the shape parameters to scan for it.
    pub fn with(&self, e: Effect) -> (Structure, Vec<ScanParam>) {
        let mut s = self.clone();
        s.effects.insert(e);
        if s.contact {
            // contact: the surface height is re-calibrated with every candidate (per fold),
            // and the exponent too once the spring is non-linear
            let scan = if !s.coupled {
                vec![]
            } else if s.has(Effect::ContactNonlinearity) {
                vec![ScanParam::NExp, ScanParam::H]
            } else {
                vec![ScanParam::H]
            };
            return (s, scan);
        }
        let scan = match e {
            Effect::Stribeck if s.has(Effect::FrictionAsymmetry) => vec![ScanParam::QsPos, ScanParam::QsNeg],
            Effect::Stribeck => vec![ScanParam::Qs],
            Effect::FrictionAsymmetry if s.has(Effect::Stribeck) => vec![ScanParam::QsPos, ScanParam::QsNeg],
            Effect::PositionRipple => vec![ScanParam::K],
            Effect::PositionTorque => vec![ScanParam::KPos],
            Effect::Delay => vec![ScanParam::Delay],
            _ => vec![],
        };
        (s, scan)
    }
}

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
    /// [`calibrate_coulomb_width`]; 0 = the exact sign).
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
    /// `delay` (time series): q⃛, and the rate and second rate of the rigid-body torque
    /// (see [`crate::prepare::Prepared::dtau_rb`]).
    pub jerk: Vec<f64>,
    pub dtau_rb: Vec<f64>,
    pub ddtau_rb: Vec<f64>,
}

impl JointSamples {
    /// The target of sample `i` under structure `st`: τ_measured − τ_rb(t − delay), the
    /// rigid-body torque of the delayed motion to second order (y itself without a delay).
    #[inline]
    pub fn target(&self, st: &Structure, i: usize) -> f64 {
        let d = st.delay;
        if d == 0.0 {
            return self.y[i];
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
            Col::Visc2 => s * v * v,
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
        self.fold.extend_from_slice(&o.fold);
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
            jerk: pick(&self.jerk),
            dtau_rb: pick(&self.dtau_rb),
            ddtau_rb: pick(&self.ddtau_rb),
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

/// Largest Coulomb smoothing width tried by [`calibrate_coulomb_width`] [rad/s].
pub const COULOMB_WIDTH_MAX: f64 = 2e-3;

impl JointSamples {
    /// Sets the Coulomb law's smoothing: s = tanh(q̇/w) on moving samples (the exact sign for
    /// w = 0), 0 at rest.
    pub fn set_coulomb_width(&mut self, w: f64) {
        for (s, &v) in self.s.iter_mut().zip(&self.v) {
            if *s != 0.0 {
                *s = if w > 0.0 { (v / w).tanh() } else { v.signum() };
            }
        }
        self.coulomb_width = w;
    }
}

/// The nominal's Coulomb law at the lowest speeds is structure, like its Stribeck shape: the
/// exact sign (a generator's, many papers'), or a tanh whose width is the simulator's 1 mrad/s
/// or another. At 1–3 mrad/s they differ by up to a quarter of the Coulomb level, and a law
/// fixed at one width leaves that difference as a narrow low-speed bump which `stribeck`
/// (q_s at the bottom of its grid) took on noise-only data with the other law. The width is
/// chosen per joint (time series) on the whole data by the nominal's SSR, 0–2 mrad/s (grid
/// 0.25 mrad/s, then six halvings), before any candidate is scored: the nominal and every
/// candidate use the same law, so the comparison between them stays fair.
pub fn calibrate_coulomb_width(js: &mut JointSamples, sh: &NominalShape, folds: usize) {
    if !js.time_series || js.contact || js.is_empty() {
        return;
    }
    let (st, scan) = Structure::nominal_for(js);
    let ssr_of = |js: &mut JointSamples, w: f64| {
        js.set_coulomb_width(w);
        evaluate(js, &st, &scan, sh, folds).full_ssr
    };
    let step0 = 0.25e-3;
    let mut best = (f64::INFINITY, 0.0);
    for k in 0..=((COULOMB_WIDTH_MAX / step0).round() as usize) {
        let w = k as f64 * step0;
        let ssr = ssr_of(js, w);
        if ssr < best.0 {
            best = (ssr, w);
        }
    }
    let mut step = step0;
    // to 4 µrad/s: at 2 mrad/s a tanh of width 0.9 mrad/s changes by 0.17 % of the Coulomb level
    // per 15 µrad/s of width (≈ 0.01 N·m on the JK5's joint 1), which `stribeck` took on
    // noise-only data when the width was refined to 31 µrad/s only
    for _ in 0..6 {
        step *= 0.5;
        let c = best.1;
        for w in [c - step, c + step] {
            if (0.0..=COULOMB_WIDTH_MAX).contains(&w) {
                let ssr = ssr_of(js, w);
                if ssr < best.0 {
                    best = (ssr, w);
                }
            }
        }
    }
    js.set_coulomb_width(best.1);
}

/// The friction part (Coulomb, viscous, Stribeck, s·q̇² columns) of a whole-data fit at
/// velocity `v`, with sgn(v) exact.
pub fn friction_part(ev: &Eval, sh: &NominalShape, v: f64) -> f64 {
    let js = JointSamples {
        y: vec![0.0],
        v: vec![v],
        s: vec![v.signum()],
        q: vec![0.0],
        t: vec![0.0],
        tn: vec![0.0],
        a: vec![0.0],
        dtau: vec![0.0],
        payload: vec![0.0],
        fold: vec![0],
        ..Default::default()
    };
    ev.columns
        .iter()
        .zip(&ev.full_theta)
        .filter(|(c, _)| matches!(c, Col::Coul(_) | Col::Visc(_) | Col::Strib(_) | Col::Visc2))
        .map(|(c, th)| th * js.col(*c, &ev.full_structure, sh, 0))
        .sum()
}

/// Fit of one structure: per-fold and whole-data results.
#[derive(Clone, Debug)]
pub struct Eval {
    pub structure: Structure,
    pub columns: Vec<Col>,
    /// Whole-data fit (shape values chosen on all data).
    pub full_structure: Structure,
    pub full_theta: Vec<f64>,
    pub full_ssr: f64,
    /// Per fold: the structure chosen on its training part, its amplitudes and held-out SSR.
    pub fold_structure: Vec<Structure>,
    pub fold_theta: Vec<Vec<f64>>,
    pub fold_ssr: Vec<f64>,
    pub heldout_ssr: f64,
    /// Samples fitted and held out (validation samples not counted).
    pub n: usize,
    pub n_params: usize,
    /// SSR of the whole-data fit on the validation samples, and their number (0: none).
    pub val_ssr: f64,
    pub val_n: usize,
}

impl Eval {
    pub fn heldout_rmse(&self) -> f64 {
        (self.heldout_ssr / self.n.max(1) as f64).sqrt()
    }
    /// RMSE on the validation runs (`None` without them).
    pub fn validation_rmse(&self) -> Option<f64> {
        (self.val_n > 0).then(|| (self.val_ssr / self.val_n as f64).sqrt())
    }
    /// Whole-data coefficient of a column.
    pub fn coef(&self, c: Col) -> Option<f64> {
        self.columns.iter().position(|&x| x == c).map(|i| self.full_theta[i])
    }
}

/// Analysis settings.
#[derive(Clone, Debug)]
pub struct AnalysisOptions {
    pub folds: usize,
    pub min_gain: f64,
    pub min_fold_wins: usize,
    pub max_steps: usize,
    /// Effects to consider.
    pub effects: Vec<Effect>,
    /// `delay` at this value (the torque channel's delay found on other joints) instead of scanned.
    pub delay_fixed: Option<f64>,
}

impl Default for AnalysisOptions {
    fn default() -> Self {
        Self { folds: 10, min_gain: 0.02, min_fold_wins: 8, max_steps: 5, effects: crate::catalogue::default_effects(), delay_fixed: None }
    }
}

/// Least squares from the Gram matrix `g` of `[X y]` (p columns): (θ, SSR).
pub(crate) fn solve(g: &DMatrix<f64>, p: usize) -> (Vec<f64>, f64) {
    // g is (p+1)x(p+1) Gram of [X y]
    // Columns are scaled to unit norm first, so the tiny ridge that keeps the solve
    // defined for collinear or empty columns is the same relative size for every column
    // (the contact spring column u·δ is ~10⁻⁵ of a constant column: an absolute ridge
    // would shrink its coefficient by several per cent).
    let scale: Vec<f64> = (0..p).map(|k| if g[(k, k)] > 0.0 { 1.0 / g[(k, k)].sqrt() } else { 1.0 }).collect();
    let mut a = DMatrix::from_fn(p, p, |r, c| g[(r, c)] * scale[r] * scale[c]);
    let b = DVector::from_fn(p, |r, _| g[(r, p)] * scale[r]);
    let yy = g[(p, p)];
    for k in 0..p {
        a[(k, k)] += 1e-9 * a[(k, k)] + 1e-12;
    }
    let z = match a.clone().cholesky() {
        Some(ch) => ch.solve(&b),
        None => a.pseudo_inverse(1e-12).map(|pi| pi * &b).unwrap_or_else(|_| DVector::zeros(p)),
    };
    let theta = DVector::from_fn(p, |r, _| z[r] * scale[r]);
    let b = g.view((0, p), (p, 1)).column(0).clone_owned();
    let ssr = (yy - 2.0 * theta.dot(&b) + (g.view((0, 0), (p, p)) * &theta).dot(&theta)).max(0.0);
    (theta.iter().copied().collect(), ssr)
}

/// SSR of the parameters `theta` on the samples of the Gram matrix `g` of `[X y]`.
pub(crate) fn heldout(g: &DMatrix<f64>, theta: &[f64]) -> f64 {
    let p = theta.len();
    let th = DVector::from_column_slice(theta);
    let b = g.view((0, p), (p, 1)).column(0).clone_owned();
    (g[(p, p)] - 2.0 * th.dot(&b) + (g.view((0, 0), (p, p)) * &th).dot(&th)).max(0.0)
}

/// Per-fold Gram matrices of `[X y]` for one structure (columns in `cols` order).
fn fold_grams(js: &JointSamples, st: &Structure, sh: &NominalShape, cols: &[Col], k_folds: usize) -> Vec<DMatrix<f64>> {
    let p = cols.len();
    // one Gram per fold, and the last one for the validation samples
    let mut g = vec![DMatrix::<f64>::zeros(p + 1, p + 1); k_folds + 1];
    let mut x = vec![0.0; p + 1];
    for i in 0..js.len() {
        for (c, xc) in cols.iter().zip(x.iter_mut()) {
            *xc = js.col(*c, st, sh, i);
        }
        x[p] = js.target(st, i);
        let gm = &mut g[gram_index(js.fold[i], k_folds)];
        for a in 0..=p {
            let xa = x[a];
            if xa == 0.0 {
                continue;
            }
            for b in a..=p {
                gm[(a, b)] += xa * x[b];
            }
        }
    }
    for gm in &mut g {
        for a in 0..=p {
            for b in 0..a {
                gm[(a, b)] = gm[(b, a)];
            }
        }
    }
    g
}

#[inline]
fn gram_index(fold: u8, k_folds: usize) -> usize {
    if fold == VALIDATION_FOLD {
        k_folds
    } else {
        fold as usize
    }
}

/// Like [`fold_grams`] for a structure that differs from the one behind `base` only in
/// the columns flagged in `scan_cols`: only their rows/columns are recomputed.
fn fold_grams_update(
    js: &JointSamples,
    st: &Structure,
    sh: &NominalShape,
    cols: &[Col],
    scan_cols: &[usize],
    base: &[DMatrix<f64>],
) -> Vec<DMatrix<f64>> {
    let p = cols.len();
    let mut g: Vec<DMatrix<f64>> = base.to_vec();
    for gm in &mut g {
        for &a in scan_cols {
            for b in 0..=p {
                gm[(a, b)] = 0.0;
                gm[(b, a)] = 0.0;
            }
        }
    }
    let mut x = vec![0.0; p + 1];
    for i in 0..js.len() {
        for (c, xc) in cols.iter().zip(x.iter_mut()) {
            *xc = js.col(*c, st, sh, i);
        }
        x[p] = js.target(st, i);
        let gm = &mut g[gram_index(js.fold[i], base.len() - 1)];
        for &a in scan_cols {
            let xa = x[a];
            if xa == 0.0 {
                continue;
            }
            for b in 0..=p {
                gm[(a, b)] += xa * x[b];
            }
        }
    }
    for gm in &mut g {
        for &a in scan_cols {
            for b in 0..=p {
                if !scan_cols.contains(&b) {
                    gm[(b, a)] = gm[(a, b)];
                }
            }
        }
    }
    g
}

/// Whether column `c` changes with the shape parameter `sp`.
fn depends_on(c: Col, sp: ScanParam) -> bool {
    matches!(
        (c, sp),
        (Col::Strib(Dir::Both), ScanParam::Qs)
            | (Col::Strib(Dir::Pos), ScanParam::QsPos)
            | (Col::Strib(Dir::Neg), ScanParam::QsNeg)
            | (Col::RipSin | Col::RipCos, ScanParam::K)
            | (Col::PosSin | Col::PosCos, ScanParam::KPos)
            | (Col::Spring | Col::CDamp, ScanParam::H)
            | (Col::Spring, ScanParam::NExp)
            // a delay shifts the motion every column is evaluated at
            | (_, ScanParam::Delay)
    )
}

/// Halvings of the grid step when refining the surface height: the contact force is
/// k·δ with k up to 10⁴–10⁵ N/m, so h must be resolved to well below 1 µm·(noise/k).
const H_HALVINGS: usize = 14;

/// Fits `st` with the shape parameters in `scan` chosen per fold (grid + refinement).
pub fn evaluate(js: &JointSamples, st: &Structure, scan: &[ScanParam], sh: &NominalShape, k_folds: usize) -> Eval {
    let cols = st.columns();
    let p = cols.len();
    // candidate value lists per scanned parameter
    let grid_of = |sp: ScanParam| -> Vec<f64> {
        match sp {
            ScanParam::K => k_grid(),
            ScanParam::KPos => k_pos_grid(),
            ScanParam::H => js.h_grid.clone(),
            ScanParam::NExp => n_exp_grid(),
            ScanParam::Delay => crate::catalogue::delay_grid(),
            _ => q_s_grid(),
        }
    };
    // additive parameters (h, n) are refined by repeated halving of the grid step;
    // log-spaced ones (q_s, k) by four multiplicative steps
    let additive = |sp: ScanParam| matches!(sp, ScanParam::H | ScanParam::NExp | ScanParam::Delay);
    // Enumerate configurations: for one parameter, its grid; for two (q_s±, disjoint
    // supports) scan each with the other fixed at its current value, then combine the
    // per-direction bests — the Gram blocks of the two directions do not interact except
    // through shared columns, which this coordinate step accounts for by re-fitting.
    let mut configs: Vec<Structure> = vec![st.clone()];
    let build = |values: &[(ScanParam, f64)]| {
        let mut s = st.clone();
        for &(sp, v) in values {
            s.set(sp, v);
        }
        s
    };
    let mut grams: Vec<Vec<DMatrix<f64>>> = Vec::new();
    if scan.is_empty() {
        grams.push(fold_grams(js, st, sh, &cols, k_folds));
    } else {
        configs.clear();
        let mut scan_cols: Vec<usize> =
            cols.iter().enumerate().filter(|(_, c)| scan.iter().any(|&sp| depends_on(**c, sp))).map(|(i, _)| i).collect();
        if scan.contains(&ScanParam::Delay) {
            scan_cols.push(p); // the delay shifts the target, the last column of [X y]
        }
        // stage 1: coarse grids, one parameter at a time (others at current values)
        let mut best_vals: Vec<f64> = scan.iter().map(|&sp| st.get(sp)).collect();
        let mut tried: Vec<(Vec<f64>, Vec<DMatrix<f64>>)> = Vec::new();
        let eval_cfg = |vals: &[f64], tried: &mut Vec<(Vec<f64>, Vec<DMatrix<f64>>)>| -> f64 {
            if let Some((_, g)) = tried.iter().find(|(v, _)| v.as_slice() == vals) {
                let tot = sum(&g[..k_folds]);
                return solve(&tot, p).1;
            }
            let pairs: Vec<(ScanParam, f64)> = scan.iter().copied().zip(vals.iter().copied()).collect();
            let s = build(&pairs);
            let g = match tried.first() {
                // only the scanned columns change between configurations
                Some((_, base)) => fold_grams_update(js, &s, sh, &cols, &scan_cols, base),
                None => fold_grams(js, &s, sh, &cols, k_folds),
            };
            let ssr = solve(&sum(&g[..k_folds]), p).1;
            tried.push((vals.to_vec(), g));
            ssr
        };
        // Exponent and surface height are strongly coupled (a power law seen from a
        // shifted surface looks like another exponent): nested search, for each n on its
        // grid (then refined by halving) a local line search of h around the current one.
        let nested = scan == [ScanParam::NExp, ScanParam::H] && js.h_grid.len() > 1;
        if nested {
            let h0 = best_vals[1];
            let line_h = |n: f64, half_width: f64, tried: &mut Vec<(Vec<f64>, Vec<DMatrix<f64>>)>| -> (f64, f64) {
                let mut best = (f64::INFINITY, h0);
                let pts = 17;
                for k in 0..pts {
                    let h = h0 - half_width + 2.0 * half_width * k as f64 / (pts - 1) as f64;
                    let ssr = eval_cfg(&[n, h], tried);
                    if ssr < best.0 {
                        best = (ssr, h);
                    }
                }
                let mut step = 2.0 * half_width / (pts - 1) as f64;
                for _ in 0..H_HALVINGS {
                    step *= 0.5;
                    let c = best.1;
                    for h in [c - step, c + step] {
                        let ssr = eval_cfg(&[n, h], tried);
                        if ssr < best.0 {
                            best = (ssr, h);
                        }
                    }
                }
                best
            };
            let ng = n_exp_grid();
            let mut best = (f64::INFINITY, best_vals[0], h0);
            for &n in &ng {
                let (ssr, h) = line_h(n, 0.008, &mut tried);
                if ssr < best.0 {
                    best = (ssr, n, h);
                }
            }
            let mut step = ng[1] - ng[0];
            for _ in 0..6 {
                step *= 0.5;
                let c = best.1;
                for n in [c - step, c + step] {
                    let (ssr, h) = line_h(n, 0.002, &mut tried);
                    if ssr < best.0 {
                        best = (ssr, n, h);
                    }
                }
            }
            best_vals = vec![best.1, best.2];
        }
        let passes = if nested { 0 } else { 1 };
        for pass in 0..passes {
            for (a, &sp) in scan.iter().enumerate() {
                let grid = grid_of(sp);
                if grid.len() < 2 {
                    continue;
                }
                let mut best = (f64::INFINITY, best_vals[a]);
                if pass == 0 {
                    for &v in &grid {
                        let mut vals = best_vals.clone();
                        vals[a] = v;
                        let ssr = eval_cfg(&vals, &mut tried);
                        if ssr < best.0 {
                            best = (ssr, v);
                        }
                    }
                } else {
                    best = (eval_cfg(&best_vals, &mut tried), best_vals[a]);
                }
                best_vals[a] = best.1;
                // stage 2: refinement around the best
                if additive(sp) {
                    let mut step = (grid[1] - grid[0]).abs();
                    if pass > 0 {
                        step *= 0.25;
                    }
                    let halvings = if sp == ScanParam::H { H_HALVINGS } else { 6 };
                    for _ in 0..halvings {
                        step *= 0.5;
                        let centre = best.1;
                        for v in [centre - step, centre + step] {
                            let mut vals = best_vals.clone();
                            vals[a] = v;
                            let ssr = eval_cfg(&vals, &mut tried);
                            if ssr < best.0 {
                                best = (ssr, v);
                            }
                        }
                    }
                } else {
                    let step = (grid[1] / grid[0]).sqrt();
                    for f in [1.0 / step, 1.0 / step.sqrt(), step.sqrt(), step] {
                        let mut vals = best_vals.clone();
                        vals[a] = best.1 * f;
                        let ssr = eval_cfg(&vals, &mut tried);
                        if ssr < best.0 {
                            best = (ssr, vals[a]);
                        }
                    }
                }
                best_vals[a] = best.1;
            }
        }
        let _ = eval_cfg(&best_vals, &mut tried);
        for (vals, g) in tried {
            let pairs: Vec<(ScanParam, f64)> = scan.iter().copied().zip(vals.iter().copied()).collect();
            configs.push(build(&pairs));
            grams.push(g);
        }
    }
    // Whole data and per fold: choose the configuration by training SSR.
    let totals: Vec<DMatrix<f64>> = grams.iter().map(|g| sum(&g[..k_folds])).collect();
    let mut full = (f64::INFINITY, 0usize, vec![]);
    for (c, tot) in totals.iter().enumerate() {
        let (th, ssr) = solve(tot, p);
        if ssr < full.0 {
            full = (ssr, c, th);
        }
    }
    let mut fold_structure = Vec::with_capacity(k_folds);
    let mut fold_theta = Vec::with_capacity(k_folds);
    let mut fold_ssr = Vec::with_capacity(k_folds);
    for f in 0..k_folds {
        let mut best = (f64::INFINITY, 0usize, vec![]);
        for (c, tot) in totals.iter().enumerate() {
            let train = tot - &grams[c][f];
            let (th, ssr) = solve(&train, p);
            if ssr < best.0 {
                best = (ssr, c, th);
            }
        }
        fold_ssr.push(heldout(&grams[best.1][f], &best.2));
        fold_structure.push(configs[best.1].clone());
        fold_theta.push(best.2);
    }
    let n_shape = st.n_shape();
    let val_n = js.fold.iter().filter(|&&f| f == VALIDATION_FOLD).count();
    let val_ssr = if val_n > 0 { heldout(&grams[full.1][k_folds], &full.2) } else { 0.0 };
    Eval {
        structure: configs[full.1].clone(),
        columns: cols,
        full_structure: configs[full.1].clone(),
        full_theta: full.2,
        full_ssr: full.0,
        heldout_ssr: fold_ssr.iter().sum(),
        fold_structure,
        fold_theta,
        fold_ssr,
        n: js.len() - val_n,
        n_params: p + n_shape,
        val_ssr,
        val_n,
    }
}

fn sum(g: &[DMatrix<f64>]) -> DMatrix<f64> {
    let mut t = g[0].clone();
    for m in &g[1..] {
        t += m;
    }
    t
}

/// Out-of-fold residuals (y − prediction of the model trained without the sample's fold),
/// and whole-data residuals.
pub fn residuals(js: &JointSamples, ev: &Eval, sh: &NominalShape) -> (Vec<f64>, Vec<f64>) {
    let mut oof = Vec::with_capacity(js.len());
    let mut ins = Vec::with_capacity(js.len());
    for i in 0..js.len() {
        let f = js.fold[i] as usize;
        // validation samples: the whole-data fit (they were never trained on either)
        let (sf, tf) = if js.is_validation(i) { (&ev.full_structure, &ev.full_theta) } else { (&ev.fold_structure[f], &ev.fold_theta[f]) };
        let mut pf = 0.0;
        let mut pa = 0.0;
        for (k, &c) in ev.columns.iter().enumerate() {
            pf += tf[k] * js.col(c, sf, sh, i);
            pa += ev.full_theta[k] * js.col(c, &ev.full_structure, sh, i);
        }
        oof.push(js.target(sf, i) - pf);
        ins.push(js.target(&ev.full_structure, i) - pa);
    }
    (oof, ins)
}

/// A candidate scored against the current model of one joint.
#[derive(Clone, Debug)]
pub struct Candidate {
    pub effect: Effect,
    pub eval: Eval,
    /// Held-out SSR of the current model (before adding the candidate).
    pub before_ssr: f64,
    pub gain: f64,
    pub fold_wins: usize,
    pub delta_bic: f64,
    /// The held-out counterpart of ΔBIC: n_eff·ln(held-out SSR ratio) + Δp·ln(n_eff). The
    /// forward selection adds the significant candidate with the lowest.
    pub heldout_bic: f64,
    pub significant: bool,
}

/// The selection history of one joint.
#[derive(Clone, Debug)]
pub struct JointResult {
    pub joint: usize,
    pub n: usize,
    pub nominal: Eval,
    /// Selected candidates in order.
    pub steps: Vec<Candidate>,
    /// Final model.
    pub final_eval: Eval,
    /// Every candidate scored against the final model (none of them significant).
    pub rejected: Vec<Candidate>,
}

/// Largest |k − 1| a `torque_scale` finding may have (a gain error, not a missing torque).
pub const TORQUE_SCALE_MAX_ERROR: f64 = 0.5;

/// Scores one candidate against the current model.
pub fn score(js: &JointSamples, cur: &Eval, e: Effect, sh: &NominalShape, o: &AnalysisOptions) -> Candidate {
    let (mut st, mut scan) = cur.full_structure.with(e);
    if let (Effect::Delay, Some(d)) = (e, o.delay_fixed) {
        st.delay = d;
        st.delay_fixed = true;
        scan.clear();
    }
    let ev = evaluate(js, &st, &scan, sh, o.folds);
    let gain = if cur.heldout_ssr > 0.0 { 1.0 - ev.heldout_ssr / cur.heldout_ssr } else { 0.0 };
    let fold_wins = ev.fold_ssr.iter().zip(&cur.fold_ssr).filter(|(a, b)| a < b).count();
    let n_eff = (ev.n as f64 / js.corr_len.max(1.0)).max(2.0);
    let dp = ev.n_params.saturating_sub(cur.n_params) as f64;
    let delta_bic = if cur.full_ssr > 0.0 && ev.full_ssr > 0.0 {
        n_eff * (ev.full_ssr / cur.full_ssr).ln() + dp * n_eff.ln()
    } else {
        0.0
    };
    // a drive gain is a gain: k = 1 + coefficient outside 0.5–1.5 is the column absorbing a
    // wrong rigid-body torque (on the real Panda joint 7 it gave k = 0.025), not a scale error
    let plausible = e != Effect::TorqueScale || ev.coef(Col::Scale).is_some_and(|c| c.abs() <= TORQUE_SCALE_MAX_ERROR);
    let significant = gain >= o.min_gain && fold_wins >= o.min_fold_wins && delta_bic < 0.0 && plausible;
    let heldout_bic = if gain < 1.0 { n_eff * (1.0 - gain).ln() + dp * n_eff.ln() } else { f64::NEG_INFINITY };
    Candidate { effect: e, eval: ev, before_ssr: cur.heldout_ssr, gain, fold_wins, delta_bic, heldout_bic, significant }
}

/// Forward selection on one joint.
pub fn analyse_joint(js: &JointSamples, sh: &NominalShape, o: &AnalysisOptions) -> JointResult {
    let (st0, scan0) = Structure::nominal_for(js);
    let nominal = evaluate(js, &st0, &scan0, sh, o.folds);
    let mut cur = nominal.clone();
    let mut steps = Vec::new();
    let rejected;
    loop {
        let mut cands: Vec<Candidate> = o
            .effects
            .iter()
            .copied()
            .filter(|e| js.applicable(*e) && !cur.full_structure.has(*e))
            .map(|e| score(js, &cur, e, sh, o))
            .collect();
        cands.sort_by(|a, b| b.gain.total_cmp(&a.gain));
        // Of the significant candidates the one with the lowest held-out BIC is added (held-out
        // gain, with ln(n_eff) per parameter): where two explain the same residual about
        // equally (a Stribeck curve whose q_s lies beyond the data mimics s·q̇²; a slow
        // sin(k'q + φ) over a joint's range mimics an offset; a delay found on the other joints
        // is a negative rotor inertia on a wrist joint), the one with fewer parameters is
        // taken, not the one whose extra freedom fits the noise a little better held out.
        let pick = cands
            .iter()
            .enumerate()
            .filter(|(_, c)| c.significant)
            .min_by(|a, b| a.1.heldout_bic.total_cmp(&b.1.heldout_bic))
            .map(|(i, _)| i);
        match pick {
            Some(i) if steps.len() < o.max_steps => {
                let c = cands.swap_remove(i);
                cur = c.eval.clone();
                steps.push(c);
            }
            _ => {
                rejected = cands;
                break;
            }
        }
    }
    JointResult { joint: js.joint, n: nominal.n, nominal, steps, final_eval: cur, rejected }
}
