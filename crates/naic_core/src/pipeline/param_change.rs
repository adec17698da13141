//! What a running controller does when its parameters change: one policy, used by the
//! `naic_controller` node (parameter services, `ros2 param set`) and by the in-process
//! simulation (`naic_sim::controllers::PipelineController::set_params`).
//!
//! 1. **Force law, impedance, contact detection or force limit changed**
//!    ([`ControlParams`] differ): the control stage restarts from the new parameters. The
//!    NAIC weights (`m_d`, `b_d`, `σ`, eq 10–15) start again from the new values, the
//!    phase is free space and contact is re-detected. A learned weight is not carried
//!    into a law whose bounds or meaning may have changed (e.g. `aic` → `naic`).
//! 2. **Any accepted change**, also one that leaves the controller's parameters as they
//!    are (e.g. only the desired force, which is part of the reference): a force-limit
//!    retraction, in progress or latched ([`super::control::ForceLimit::latch`]), ends
//!    ([`ControlState::resume`]); the tool is allowed back onto the surface. This is how
//!    an operator acknowledges the over-force event.
//!
//! Everything else of the state (sense filter, F/T tare, fault count) is kept.

use super::control::ControlState;
use super::controller::{Controller, ControllerParams, ControllerState};

/// What a parameter change did to the state.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Outcome {
    /// The control stage restarted from the new parameters (rule 1).
    pub restarted: bool,
    /// A force-limit retraction was ended (by rule 1 or 2).
    pub resumed: bool,
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
    let was_retracting = s.control.retracting();
    let mut state = *s;
    let restarted = new.control != c.params().control;
    state.control = if restarted { ControlState::new(&new.control) } else { s.control.resume() };
    let outcome = Outcome { restarted, resumed: was_retracting && !state.control.retracting() };
    Ok((next, state, outcome))
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
    fn same_parameters_keep_the_weights_and_open_the_latch() {
        let c = controller();
        let s = running(&c);
        assert!(s.control.retracting());
        let (c2, s2, o) = apply(&c, &s, *c.params()).unwrap();
        assert_eq!(o, Outcome { restarted: false, resumed: true });
        assert_eq!(c2.params(), c.params());
        assert!(!s2.control.retracting() && s2.control.phase == Phase::Free);
        assert_eq!(s2.control.law, s.control.law, "learned weights kept");
        assert_eq!(s2.fault_count, 3);
        // Without a retraction: nothing changes at all.
        let mut s = running(&c);
        s.control.retract_hold = None;
        let (_, s3, o) = apply(&c, &s, *c.params()).unwrap();
        assert_eq!((o, s3), (Outcome::default(), s));
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
            assert_eq!(o, Outcome { restarted: true, resumed: true });
            assert_eq!(*c2.params(), new);
            assert_eq!(s2.control, ControlState::new(&new.control));
            assert_eq!(s2.control.law.m_d, new.control.impedance.m_d[new.control.force_axis.axis]);
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
