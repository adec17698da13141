//! Friction laws of one joint ([`JointFriction`]) and of a whole arm ([`FrictionModel`]).
//!
//! * Equation 4 (Coulomb + viscous): `τ_f = f_c·sgn(q̇) + f_v·q̇`.
//! * Equation 5 (Stribeck, symmetric): `τ_f = [f_a + (f_b − f_a)·e^{−(q̇/q_s)²}]·sgn(q̇) + f_v·q̇`,
//!   with f_a the Coulomb level at high speed and f_b the breakaway (static) level.
//! * Equation 5 per direction (Table 1): one parameter set for q̇ > 0 and one for q̇ < 0,
//!   all four given as positive magnitudes. The negative branch is
//!   `τ_f = −[f_a⁻ + (f_b⁻ − f_a⁻)·e^{−(q̇/q_s⁻)²}] + f_v⁻·q̇` — i.e. exactly equation 5
//!   with sgn(q̇) = −1, the same form the authors fitted to the q̇ < 0 half of their data.
//!   (q_s enters squared, so its sign is irrelevant; a positive f_v⁻ makes the
//!   torque more negative as q̇ becomes more negative, i.e. it dissipates.)
//!
//! The exact laws use sgn(0) = 0: at standstill they return 0 (static friction is
//! set-valued there, and a feedforward should not push in either direction).
//!
//! The smooth variant ([`Smoothing::Tanh`]) replaces sgn(q̇) by s = tanh(q̇/v_s) and,
//! for the per-direction law, blends the two branches with weights (1 ± s)/2:
//! `τ_f = s·[w⁺ g⁺(q̇) + w⁻ g⁻(q̇)] + (w⁺ f_v⁺ + w⁻ f_v⁻)·q̇`, where g is the Stribeck
//! magnitude of each branch. It is C^∞, passes through 0 at q̇ = 0, and differs from the
//! exact law by less than 0.5 % of the Coulomb/Stribeck term once |q̇| ≥ 3·v_s
//! (tanh 3 = 0.995). Its steepest slope, near q̇ = 0, is [`JointFriction::max_slope`]
//! ≈ f_b/v_s + f_v: a simulator that integrates friction explicitly needs
//! `max_slope·dt / I_joint < 2` (or must treat friction implicitly).

use super::FrictionError;
use serde::{Deserialize, Serialize};

/// Default smoothing velocity v_s of [`Smoothing::Tanh`]: 1 mrad/s. The slowest
/// segment in the JK5 friction data is 3 mrad/s, so at every measured speed the
/// smooth law is within 0.5 % of equation 5, while the smallest identified Stribeck
/// velocity (joint 3, q_s ≈ 4 mrad/s) keeps its shape.
pub const DEFAULT_V_S: f64 = 1e-3;

/// The four parameters of equation 5 for one direction, as positive magnitudes.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct StribeckParams {
    /// Coulomb level at high speed, N·m (≥ 0).
    pub f_a: f64,
    /// Breakaway (static) level, N·m (≥ 0).
    pub f_b: f64,
    /// Stribeck velocity, rad/s (> 0).
    pub q_s: f64,
    /// Viscous coefficient, N·m·s/rad (≥ 0).
    pub f_v: f64,
}

impl StribeckParams {
    /// The Stribeck magnitude g(q̇) = f_a + (f_b − f_a)·e^{−(q̇/q_s)²} (eq. 5, without sign and viscous term).
    #[inline]
    pub fn magnitude(&self, qdot: f64) -> f64 {
        let x = qdot / self.q_s;
        self.f_a + (self.f_b - self.f_a) * (-x * x).exp()
    }

    /// g(q̇) as [`Self::magnitude`] (bit-identical) and its slope dg/dq̇ = −2 q̇/q_s² · (f_b − f_a)·e^{−(q̇/q_s)²}.
    #[inline]
    fn magnitude_and_slope(&self, qdot: f64) -> (f64, f64) {
        let x = qdot / self.q_s;
        let e = (self.f_b - self.f_a) * (-x * x).exp();
        (self.f_a + e, -2.0 * x / self.q_s * e)
    }

    /// Checks the physical bounds; `what` names the joint/direction in the message.
    pub fn validate(&self, what: &str) -> Result<(), FrictionError> {
        nonneg(what, "f_a", self.f_a, "the Coulomb level at high speed, N·m")?;
        nonneg(what, "f_b", self.f_b, "the breakaway (static) level, N·m")?;
        nonneg(what, "f_v", self.f_v, "the viscous coefficient, N·m·s/rad (viscous friction dissipates)")?;
        if !self.q_s.is_finite() || self.q_s <= 0.0 {
            return Err(FrictionError::Params(format!(
                "{what}: q_s = {} is invalid; q_s is the Stribeck velocity in rad/s and must be a finite number > 0 \
                 (its sign does not matter in eq. 5, so give its magnitude)",
                self.q_s
            )));
        }
        Ok(())
    }
}

pub(crate) fn nonneg(what: &str, field: &str, v: f64, meaning: &str) -> Result<(), FrictionError> {
    if !v.is_finite() || v < 0.0 {
        return Err(FrictionError::Params(format!(
            "{what}: {field} = {v} is invalid; {field} is {meaning} and must be a finite number ≥ 0"
        )));
    }
    Ok(())
}

/// The friction law of one joint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum JointFriction {
    /// Equation 4: `f_c·sgn(q̇) + f_v·q̇`.
    CoulombViscous { f_c: f64, f_v: f64 },
    /// Equation 5, the same parameters in both directions.
    Stribeck(StribeckParams),
    /// Equation 5 per direction (Table 1): `positive` for q̇ > 0, `negative` for q̇ < 0.
    StribeckPerDirection { positive: StribeckParams, negative: StribeckParams },
}

impl JointFriction {
    /// Friction torque (N·m) at joint velocity `qdot` (rad/s), exact law, sgn(0) = 0.
    #[inline]
    pub fn tau_f(&self, qdot: f64) -> f64 {
        if qdot == 0.0 || qdot.is_nan() {
            return 0.0;
        }
        match self {
            Self::CoulombViscous { f_c, f_v } => f_c * qdot.signum() + f_v * qdot,
            Self::Stribeck(p) => p.magnitude(qdot) * qdot.signum() + p.f_v * qdot,
            Self::StribeckPerDirection { positive, negative } => {
                if qdot > 0.0 {
                    positive.magnitude(qdot) + positive.f_v * qdot
                } else {
                    -negative.magnitude(qdot) + negative.f_v * qdot
                }
            }
        }
    }

    /// Friction torque of the smooth variant: sgn(q̇) replaced by tanh(q̇/v_s) (see module docs).
    /// `v_s` must be > 0 (checked where the smoothing is configured, in [`FrictionModel::with_smoothing`]).
    #[inline]
    pub fn tau_f_smooth(&self, qdot: f64, v_s: f64) -> f64 {
        let s = (qdot / v_s).tanh();
        match self {
            Self::CoulombViscous { f_c, f_v } => f_c * s + f_v * qdot,
            Self::Stribeck(p) => p.magnitude(qdot) * s + p.f_v * qdot,
            Self::StribeckPerDirection { positive, negative } => {
                let w_pos = 0.5 * (1.0 + s);
                let w_neg = 0.5 * (1.0 - s);
                s * (w_pos * positive.magnitude(qdot) + w_neg * negative.magnitude(qdot))
                    + (w_pos * positive.f_v + w_neg * negative.f_v) * qdot
            }
        }
    }

    /// [`Self::tau_f_smooth`] (bit-identical) and its slope ∂τ_f/∂q̇ in N·m·s/rad, analytic,
    /// for implicit integrators. For the per-direction law the branch whose weight
    /// (1 ± s)/2 is exactly 0 (|q̇| ≳ 19 v_s, where tanh rounds to ±1) is not evaluated.
    #[inline]
    pub fn tau_f_smooth_and_slope(&self, qdot: f64, v_s: f64) -> (f64, f64) {
        let s = (qdot / v_s).tanh();
        let ds = (1.0 - s * s) / v_s;
        match self {
            Self::CoulombViscous { f_c, f_v } => (f_c * s + f_v * qdot, f_c * ds + f_v),
            Self::Stribeck(p) => {
                let (g, dg) = p.magnitude_and_slope(qdot);
                (g * s + p.f_v * qdot, dg * s + g * ds + p.f_v)
            }
            Self::StribeckPerDirection { positive, negative } => {
                let w_pos = 0.5 * (1.0 + s);
                let w_neg = 0.5 * (1.0 - s);
                let (g_pos, dg_pos) = if w_pos == 0.0 { (0.0, 0.0) } else { positive.magnitude_and_slope(qdot) };
                let (g_neg, dg_neg) = if w_neg == 0.0 { (0.0, 0.0) } else { negative.magnitude_and_slope(qdot) };
                let g = w_pos * g_pos + w_neg * g_neg;
                let f_v = w_pos * positive.f_v + w_neg * negative.f_v;
                let dw = 0.5 * ds; // dw⁺/dq̇ = −dw⁻/dq̇
                let dg = dw * (g_pos - g_neg) + w_pos * dg_pos + w_neg * dg_neg;
                (s * g + f_v * qdot, ds * g + s * dg + dw * (positive.f_v - negative.f_v) * qdot + f_v)
            }
        }
    }

    /// Steepest slope max |dτ_f/dq̇| of the smooth variant (N·m·s/rad), found numerically
    /// (central differences on a fine grid over |q̇| ≤ 10·v_s and over |q̇| ≤ 10·max(v_s, q_s)).
    /// For the symmetric laws it is at q̇ = 0 and ≈ f_b/v_s + f_v; for an asymmetric
    /// per-direction law it lies slightly on the side of the larger breakaway level.
    /// A simulator that integrates friction explicitly with step dt on a joint with
    /// inertia I needs `max_slope·dt/I < 2`. Not meant for the 1 kHz path.
    pub fn max_slope(&self, v_s: f64) -> f64 {
        let q_s = match self {
            Self::CoulombViscous { .. } => 0.0,
            Self::Stribeck(p) => p.q_s,
            Self::StribeckPerDirection { positive, negative } => positive.q_s.max(negative.q_s),
        };
        let d = 1e-4 * v_s;
        let slope = |v: f64| ((self.tau_f_smooth(v + d, v_s) - self.tau_f_smooth(v - d, v_s)) / (2.0 * d)).abs();
        let mut best: f64 = 0.0;
        for half_width in [10.0 * v_s, 10.0 * v_s.max(q_s)] {
            for k in 0..=4000 {
                best = best.max(slope(half_width * (k as f64 / 2000.0 - 1.0)));
            }
        }
        best
    }

    /// Checks the physical bounds of every parameter; `what` names the joint in the message.
    pub fn validate(&self, what: &str) -> Result<(), FrictionError> {
        match self {
            Self::CoulombViscous { f_c, f_v } => {
                nonneg(what, "f_c", *f_c, "the Coulomb level, N·m")?;
                nonneg(what, "f_v", *f_v, "the viscous coefficient, N·m·s/rad (viscous friction dissipates)")
            }
            Self::Stribeck(p) => p.validate(what),
            Self::StribeckPerDirection { positive, negative } => {
                positive.validate(&format!("{what}, positive direction"))?;
                negative.validate(&format!("{what}, negative direction"))
            }
        }
    }

    /// Short name of the law as used in the YAML `model:` field.
    pub fn model_name(&self) -> &'static str {
        match self {
            Self::CoulombViscous { .. } => "coulomb_viscous",
            Self::Stribeck(_) => "stribeck",
            Self::StribeckPerDirection { .. } => "stribeck_per_direction",
        }
    }
}

/// How sgn(q̇) is evaluated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Smoothing {
    /// The laws as printed (sgn, discontinuous at 0): for feedforward on the real robot.
    Exact,
    /// sgn(q̇) → tanh(q̇/v_s), v_s in rad/s: for simulation (see module docs).
    Tanh { v_s: f64 },
}

/// Friction of an n-joint arm: one [`JointFriction`] per joint, evaluated without allocation.
#[derive(Clone, Debug, PartialEq)]
pub struct FrictionModel {
    joints: Vec<JointFriction>,
    smoothing: Smoothing,
}

impl FrictionModel {
    /// A model with the exact laws; validates every joint (index 0 = joint 1).
    pub fn new(joints: Vec<JointFriction>) -> Result<Self, FrictionError> {
        if joints.is_empty() {
            return Err(FrictionError::Params(
                "a friction model needs at least one joint; give one law per joint".into(),
            ));
        }
        for (i, j) in joints.iter().enumerate() {
            j.validate(&format!("joint {}", i + 1))?;
        }
        Ok(Self { joints, smoothing: Smoothing::Exact })
    }

    /// The same model evaluated with another [`Smoothing`]; `v_s` must be finite and > 0.
    pub fn with_smoothing(mut self, smoothing: Smoothing) -> Result<Self, FrictionError> {
        if let Smoothing::Tanh { v_s } = smoothing {
            if !v_s.is_finite() || v_s <= 0.0 {
                return Err(FrictionError::Params(format!(
                    "smoothing velocity v_s = {v_s} is invalid; it must be a finite number of rad/s > 0 \
                     (default {DEFAULT_V_S})"
                )));
            }
        }
        self.smoothing = smoothing;
        Ok(self)
    }

    pub fn smoothing(&self) -> Smoothing {
        self.smoothing
    }

    pub fn n_joints(&self) -> usize {
        self.joints.len()
    }

    /// The law of joint `joint` (0-based), if there is one.
    pub fn joint(&self, joint: usize) -> Option<&JointFriction> {
        self.joints.get(joint)
    }

    pub fn joints(&self) -> &[JointFriction] {
        &self.joints
    }

    /// Friction torque of joint `joint` (0-based) at velocity `qdot`, with this model's smoothing.
    /// Panics if `joint >= n_joints()` (a programming error, like slice indexing).
    #[inline]
    pub fn tau_f(&self, joint: usize, qdot: f64) -> f64 {
        let j = &self.joints[joint];
        match self.smoothing {
            Smoothing::Exact => j.tau_f(qdot),
            Smoothing::Tanh { v_s } => j.tau_f_smooth(qdot, v_s),
        }
    }

    /// Friction torque of joint `joint` and its slope ∂τ_f/∂q̇ (N·m·s/rad) at `qdot`.
    /// With [`Smoothing::Tanh`] the torque is bit-identical to [`Self::tau_f`] and the slope
    /// analytic ([`JointFriction::tau_f_smooth_and_slope`]); the exact laws have no
    /// derivative at 0, so with [`Smoothing::Exact`] the slope is the central difference
    /// over ±1e-7 rad/s. Panics if `joint >= n_joints()`.
    #[inline]
    pub fn tau_f_and_slope(&self, joint: usize, qdot: f64) -> (f64, f64) {
        let j = &self.joints[joint];
        match self.smoothing {
            Smoothing::Tanh { v_s } => j.tau_f_smooth_and_slope(qdot, v_s),
            Smoothing::Exact => {
                let d = 1e-7;
                (j.tau_f(qdot), (j.tau_f(qdot + d) - j.tau_f(qdot - d)) / (2.0 * d))
            }
        }
    }

    /// Friction torques of all joints written into `tau_f` (no allocation).
    /// Both slices must have `n_joints()` entries.
    #[inline]
    pub fn tau_f_into(&self, qdot: &[f64], tau_f: &mut [f64]) -> Result<(), FrictionError> {
        let n = self.joints.len();
        if qdot.len() != n {
            return Err(FrictionError::Length { what: "qdot", expected: n, found: qdot.len() });
        }
        if tau_f.len() != n {
            return Err(FrictionError::Length { what: "tau_f", expected: n, found: tau_f.len() });
        }
        for ((out, j), &v) in tau_f.iter_mut().zip(&self.joints).zip(qdot) {
            *out = match self.smoothing {
                Smoothing::Exact => j.tau_f(v),
                Smoothing::Tanh { v_s } => j.tau_f_smooth(v, v_s),
            };
        }
        Ok(())
    }
}
