//! Stage 4 of the pipeline: joint friction feedforward (paper §5.1).
//!
//! The identified friction (eq 5, per direction as in Table 1, or any model
//! of [`crate::friction`]) is added to the controller's torque: `τ = τ_ctrl +
//! τ_f(q̇)`, the joint-space form of eq 6's `F_f` (`τ_f = Jᵀ F_f`). It is
//! evaluated at the median-filtered measured velocity. Near `q̇ = 0` the
//! printed law jumps by `f_b⁺ + f_b⁻` (35 N·m on joint 1); evaluating it with
//! the model's smoothing (`tanh(q̇/v_s)`) keeps encoder and velocity noise at
//! rest from turning into torque chatter.
//!
//! # On the reference velocity (the scheduled law)
//!
//! The smoothing is not enough: the encoders' velocity noise (2 mrad/s, 1 σ, per joint in
//! the simulator) is twice `v_s` = 1 mrad/s, so at rest the law still applies nearly
//! `±f_b` at random on every joint (joint 1: ±12 N·m of command SD). Widening `v_s` to the
//! noise loses the compensation of the joints that creep at a few mrad/s while the tool
//! slides (docs/controller.md, round 4). The standard remedy is to evaluate the friction
//! law at the *reference* velocity, which carries no noise: [`blend`] gives the velocity
//! the law is evaluated at,
//!
//! ```text
//! q̇_ff,i = w_i q̇_i + (1 − w_i) q̇_ref,i,   w_i = max(ρ(q̇_i), ρ(q̇_ref,i)),   ρ(v) = clamp((|v| − v_lo) / (v_hi − v_lo), 0, 1)
//! ```
//!
//! with `q̇_ref = J⁻¹ Ẋ_ref` the joint velocity of the twist the controller commands (the
//! controller computes it, [`super::controller::ControlOutputs::dq_ff`]): the measured
//! velocity as before wherever the joint or its reference moves above the noise
//! (`≥ v_hi`: a motion the reference does not know, an impact, a slip, or a joint that
//! follows the reference), the reference's only near rest (both below `v_lo`), so a joint
//! at rest with a reference at rest gets no feedforward whatever its velocity noise.
//! (Evaluated at the reference also where the reference moves, round 5's try 2 in
//! docs/controller.md, the joints the reference moves but that stick lose the measured
//! velocity's dither, and the slope at d = 2 settled later.)

use crate::friction::FrictionModel;
use crate::pipeline::ConfigError;
use crate::{JointVec, N_JOINTS};

/// The blend of measured and reference joint velocity for the friction feedforward
/// (module docs): the reference velocity where both the measured and the reference speed
/// are below `v_lo` [rad/s], the measured one where either is above `v_hi`, linear in between.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceBlend {
    pub v_lo: f64,
    pub v_hi: f64,
}

impl ReferenceBlend {
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !(self.v_lo >= 0.0 && self.v_lo < self.v_hi && self.v_hi.is_finite()) {
            return Err(ConfigError::invalid(
                "friction reference blend v_lo",
                self.v_lo,
                format!("rad/s must be >= 0 and below v_hi = {} rad/s (finite)", self.v_hi),
            ));
        }
        Ok(())
    }
}

/// The joint velocity the friction law is evaluated at (module docs): per joint the
/// measured `dq` where `|dq|` or `|dq_ref|` is at least `v_hi`, the reference `dq_ref`
/// where both are at most `v_lo`, linear in between. A non-finite `dq_ref` entry gives the
/// measured velocity.
pub fn blend(b: &ReferenceBlend, dq: &JointVec, dq_ref: &JointVec) -> JointVec {
    std::array::from_fn(|i| {
        if !dq_ref[i].is_finite() {
            return dq[i];
        }
        let w = |v: f64| ((v.abs() - b.v_lo) / (b.v_hi - b.v_lo)).clamp(0.0, 1.0);
        let w = w(dq[i]).max(w(dq_ref[i]));
        w * dq[i] + (1.0 - w) * dq_ref[i]
    })
}

/// One cycle: `τ_ctrl + τ_f(q̇)`. A model with a joint count other than [`N_JOINTS`]
/// adds nothing.
pub fn step(model: &FrictionModel, dq: &JointVec, tau_ctrl: &JointVec) -> JointVec {
    let mut tau_f = [0.0; N_JOINTS];
    if model.tau_f_into(dq, &mut tau_f).is_err() {
        return *tau_ctrl;
    }
    std::array::from_fn(|i| tau_ctrl[i] + tau_f[i])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::friction::{FrictionModel, JointFriction};

    #[test]
    fn adds_the_friction_torque_of_each_joint() {
        let joints = (0..6).map(|i| JointFriction::CoulombViscous { f_c: 1.0 + i as f64, f_v: 0.5 }).collect();
        let m = FrictionModel::new(joints).unwrap();
        let dq = [0.2, -0.2, 0.0, 1.0, -1.0, 0.1];
        let tau = step(&m, &dq, &[10.0; 6]);
        for i in 0..6 {
            assert!((tau[i] - (10.0 + m.tau_f(i, dq[i]))).abs() < 1e-15);
        }
        assert!((tau[0] - (10.0 + 1.0 + 0.1)).abs() < 1e-12);
        assert!((tau[1] - (10.0 - 2.0 - 0.1)).abs() < 1e-12);
    }

    #[test]
    fn the_blend_takes_the_reference_only_near_rest() {
        let b = ReferenceBlend { v_lo: 0.004, v_hi: 0.008 };
        let dq = [0.003, -0.003, 0.006, 0.02, 0.002, 0.001];
        let dq_ref = [0.0, 0.01, 0.001, -0.05, 0.006, f64::NAN];
        let v = blend(&b, &dq, &dq_ref);
        // Both at rest (the measurement within the noise): the reference.
        assert_eq!(v[0], 0.0);
        // The reference moves: the measured velocity, as without the blend.
        assert_eq!(v[1], -0.003);
        assert_eq!(v[3], 0.02);
        // Half-way through the band (measured, reference at rest): the mean.
        assert!((v[2] - 0.5 * (0.006 + 0.001)).abs() < 1e-15, "{}", v[2]);
        assert!((v[4] - 0.5 * (0.002 + 0.006)).abs() < 1e-15, "{}", v[4]);
        // No reference: the measured velocity.
        assert_eq!(v[5], 0.001);
        // At rest with a reference at rest, noise does not reach the friction torque.
        let joints = (0..6).map(|_| JointFriction::CoulombViscous { f_c: 10.0, f_v: 0.5 }).collect();
        let m = FrictionModel::new(joints).unwrap();
        let noise = [0.0035, -0.0039, 0.002, -0.001, 0.0, 0.003];
        assert_eq!(step(&m, &blend(&b, &noise, &[0.0; 6]), &[1.0; 6]), [1.0; 6]);
    }

    #[test]
    fn a_blend_band_that_is_empty_or_not_finite_is_refused() {
        assert!(ReferenceBlend { v_lo: 0.004, v_hi: 0.008 }.validate().is_ok());
        for (lo, hi) in [(0.008, 0.004), (0.004, 0.004), (-1.0, 0.004), (0.0, f64::INFINITY), (f64::NAN, 0.1)] {
            let e = ReferenceBlend { v_lo: lo, v_hi: hi }.validate().unwrap_err().to_string();
            assert!(e.contains("v_lo") && e.contains("v_hi"), "{e}");
        }
    }
}
