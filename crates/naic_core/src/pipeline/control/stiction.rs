//! The `derived` law's stiction-aware force hold (issue 42 item 6; docs/controller.md,
//! "The stiction-aware hold").
//!
//! In contact a joint whose reference is at rest is held by its own static friction. The
//! friction feedforward (eq 5, `pipeline::feedforward`) evaluated at that joint's measured
//! velocity sees only the encoders' velocity noise (about 2 mrad/s, twice the friction
//! law's smoothing `v_s` = 1 mrad/s), so it applies `± τ_s` at random: a dither of the full
//! static friction on every stuck joint (measured on the JK5 in contact: joint 5 flips
//! between −2.9 and +3.4 N·m, joint 1 spans 33 N·m), which through `Jᵀ` is a push along `n`
//! far beyond the force band. A flip that breaks a joint away moves the tip and the force
//! jumps; the joint sticks again, and the next flip repeats it: the force hunts at the rate
//! of the noise's sign changes (tens of Hz), not at the force loop's.
//!
//! The hold: in contact the feedforward is evaluated at the reference twist's joint velocity
//! wherever both the measured and the reference speed of a joint are within the velocity
//! noise (the reference blend, [`crate::pipeline::feedforward::blend`]), so a stuck joint
//! gets no torque from noise and stays stuck; a joint that moves, or whose reference moves
//! (a slip, a slide), keeps the measured velocity and its full compensation. What breaks a
//! stuck arm away is then only the force loop: its proportional part at once, its integral
//! after winding up the rest of the static friction's force-axis equivalent `ΔF_s`, in
//! `ΔF_s / (k_i |e_f|)` (docs/controller.md has the limit cycle on paper).
//!
//! No parameter of its own: the blend's bounds are the controller's `friction_reference`
//! (the scheduled law's setting, `v_lo` = 4 mrad/s, `v_hi` = 8 mrad/s: 2 and 4 σ of the
//! encoders' velocity noise); `None` there turns the hold off. Free space is unchanged.
//!
//! Pure, no allocation.

use super::law::{FrictionVelocity, Regime};
use crate::pipeline::feedforward::ReferenceBlend;

/// The friction feedforward's velocity the derived law names this cycle: in contact the
/// reference blend `blend` (the hold), elsewhere the measured velocity (`None`).
pub fn friction_velocity(blend: Option<ReferenceBlend>, regime: Regime) -> Option<FrictionVelocity> {
    match regime {
        Regime::Contact => blend.map(|b| FrictionVelocity { blend: b, fast: None }),
        Regime::Free | Regime::Retracting => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::feedforward;

    /// A stuck joint in contact (reference at rest, measured velocity the encoders' noise)
    /// gets no friction torque from that noise with the hold, and nearly the full `± τ_s`
    /// at random without it; a joint that slides keeps its measured velocity. Free space and
    /// a retraction keep the measured velocity; no blend, no hold.
    #[test]
    fn a_stuck_joint_gets_no_friction_dither_in_contact() {
        // The friction law of the test: level 3 N·m, tanh-smoothed at v_s = 1 mrad/s.
        let tau = |v: f64| 3.0 * (v / 0.001).tanh();
        let blend = ReferenceBlend { v_lo: 0.004, v_hi: 0.008 };
        let fv = friction_velocity(Some(blend), Regime::Contact).expect("the hold names a velocity in contact");
        // Joint 1 stuck with +2 mrad/s of noise, joint 2 stuck with −2 mrad/s, joint 3 sliding.
        let dq = [0.002, -0.002, 0.2, 0.0, 0.0, 0.0];
        let dq_ref = [0.0, 0.0, 0.2, 0.0, 0.0, 0.0];
        let v = feedforward::blend(&fv.blend, &dq, &dq_ref);
        assert_eq!((v[0], v[1], v[2]), (0.0, 0.0, 0.2));
        assert!(tau(dq[0]) > 2.8 && tau(dq[1]) < -2.8, "without the hold: ± τ_s from noise");
        assert_eq!((tau(v[0]), tau(v[1])), (0.0, 0.0));
        assert!(friction_velocity(Some(blend), Regime::Free).is_none());
        assert!(friction_velocity(Some(blend), Regime::Retracting).is_none());
        assert!(friction_velocity(None, Regime::Contact).is_none());
    }
}
