//! What a running controller does when its parameters change: one policy, used by the
//! `naic_controller` node (parameter services, `ros2 param set`) and by the in-process
//! simulation (`naic_sim::controllers::PipelineController::set_params`).
//!
//! 1. **Force law, impedance, contact detection or force limit changed**
//!    ([`ControlParams`] differ): the control stage restarts from the new parameters. The
//!    NAIC weights (`m_d`, `b_d`, `σ`, eq 10–15) start again from the new values, the
//!    phase is free space and contact is re-detected. A learned weight is not carried
//!    into a law whose bounds or meaning may have changed (e.g. `aic` → `naic`).
//! 2. **A force-limit retraction**, in progress or latched
//!    ([`super::control::ForceLimit::latch`]), is kept through every parameter change, also
//!    through a restart by rule 1: a parameter set is no acknowledgement of an over-force
//!    event (a new set point, e.g. 20 N after a retract at 54 N, must not put the tool back
//!    on the surface by the way). Only [`reset_force_limit`] ends it: the node's
//!    `~/reset_force_limit` service, an explicit act of the operator.
//!
//! Everything else of the state (sense filter, F/T tare, fault count) is kept.

use super::control::ControlState;
use super::controller::{Controller, ControllerParams, ControllerState};

/// What a parameter change did to the state.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Outcome {
    /// The control stage restarted from the new parameters (rule 1).
    pub restarted: bool,
}

/// Apply the accepted parameters `new` to the running controller `c` in state `s`.
/// `Err` (the core refused `new`): nothing changes. Allocates (a new [`Controller`]
/// holds its own model): called on a parameter change, never in the 1 kHz step.
pub fn apply<const N: usize>(
    c: &Controller<N>,
    s: &ControllerState<N>,
    new: ControllerParams<N>,
) -> Result<(Controller<N>, ControllerState<N>, Outcome), super::ConfigError> {
    let next = c.with_params(new)?;
    let mut state = *s;
    let restarted = new.control != c.params().control;
    if restarted {
        // Rule 2: the retraction (cycles left, latched offset) and its free-space phase stay.
        let fresh = ControlState::new(&new.control);
        state.control = if s.control.retracting() {
            ControlState { retract_left: s.control.retract_left, retract_hold: s.control.retract_hold, ..fresh }
        } else {
            fresh
        };
    }
    Ok((next, state, Outcome { restarted }))
}

/// The operator's acknowledgement of an over-force event: a force-limit retraction, in
/// progress or latched, ends ([`ControlState::resume`]: free space, contact re-detected,
/// the learned weights kept). `None` when none is in progress: nothing changes.
pub fn reset_force_limit<const N: usize>(s: &ControllerState<N>) -> Option<ControllerState<N>> {
    s.control.retracting().then(|| ControllerState { control: s.control.resume(), ..*s })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Model;
    use crate::pipeline::control::{force_law::Mode, Phase};

    fn controller() -> Controller {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../urdf/jk5.urdf");
        let model = Model::from_urdf_file(root).unwrap();
        let p = ControllerParams::paper_defaults(&model, Mode::Naic, crate::pipeline::control::force_law::DEFAULT_GAMMA);
        Controller::new(model, p).unwrap()
    }

    /// A state in contact, with learned weights, a latched force limit and some history.
    fn running(c: &Controller) -> ControllerState {
        let mut s = c.initial_state();
        s.fault_count = 3;
        s.control.phase = Phase::Contact;
        s.control.law.m_d *= 0.5;
        s.control.law.b_d *= 1.5;
        s.control.retract_hold = Some(0.01);
        s
    }

    #[test]
    fn same_parameters_change_nothing_and_keep_the_latch() {
        let c = controller();
        let s = running(&c);
        assert!(s.control.retracting());
        let (c2, s2, o) = apply(&c, &s, *c.params()).unwrap();
        assert_eq!(o, Outcome { restarted: false });
        assert_eq!(c2.params(), c.params());
        assert_eq!(s2, s, "the latch, the weights and everything else kept");
    }

    #[test]
    fn only_the_explicit_reset_opens_the_latch() {
        let c = controller();
        let s = running(&c);
        let s2 = reset_force_limit(&s).expect("a latched state resets");
        assert!(!s2.control.retracting() && s2.control.phase == Phase::Free);
        assert_eq!(s2.control.law, s.control.law, "learned weights kept");
        assert_eq!((s2.fault_count, s2.tare), (3, s.tare));
        // A retraction in progress ends too; without one there is nothing to reset.
        let mut r = running(&c);
        (r.control.retract_hold, r.control.retract_left) = (None, 40);
        assert!(!reset_force_limit(&r).unwrap().control.retracting());
        assert_eq!(reset_force_limit(&s2), None);
    }

    #[test]
    fn a_new_force_law_or_impedance_restarts_the_weights_from_the_parameters() {
        let c = controller();
        let s = running(&c);
        let mut aic = *c.params();
        aic.control.force_law.mode = Mode::Aic;
        let mut stiffer = *c.params();
        stiffer.control.impedance.m_d[2] *= 2.0;
        for new in [aic, stiffer] {
            let (c2, s2, o) = apply(&c, &s, new).unwrap();
            assert_eq!(o, Outcome { restarted: true });
            assert_eq!(*c2.params(), new);
            // The retraction survives the restart (rule 2); the rest starts afresh.
            let fresh = ControlState::new(&new.control);
            assert_eq!(s2.control, ControlState { retract_hold: s.control.retract_hold, ..fresh });
            assert!(s2.control.retracting());
            assert_eq!(s2.control.law.m_d, new.control.force_axis.along(&new.control.impedance.m_d));
            assert_eq!((s2.fault_count, s2.sense, s2.tare), (s.fault_count, s.sense, s.tare), "the rest is kept");
        }
    }

    #[test]
    fn refused_parameters_change_nothing() {
        let c = controller();
        let mut bad = *c.params();
        bad.hold_damping[0] = f64::NAN;
        assert!(apply(&c, &running(&c), bad).unwrap_err().to_string().contains("hold_damping"));
    }
}
