//! The 1 kHz control path, one module per stage, in the order data flows:
//!
//! ```text
//! sensors ─▶ sense ─▶ estimate ─▶ control ─▶ feedforward ─▶ actuate ─▶ drives
//!            (validity,  (F/T tare,   (eq 6–15,    (friction     (rate limit,
//!             median)     tool weight) RNEA → τ)    eq 5, §5.1)   saturation)
//! ```
//!
//! [`reference::step`] makes the reference the controller follows from the
//! user's `/naic/target_pose` and `/naic/desired_wrench` samples (checked,
//! speed/acceleration limited, held when stale).
//! [`controller::step`] runs the first three stages (the `naic_controller`
//! node); [`feedforward::step`] and [`actuate::step`] the last two (the
//! `friction_compensation` node and the drive guard). [`step`] composes all
//! five for in-process use; [`param_change`] is what a running controller does when its
//! parameters change (node and simulation alike). Every stage is a pure function
//! `(params, state, inputs) -> (state, outputs)` with no heap allocation.
pub mod actuate;
pub mod control;
pub mod controller;
pub mod estimate;
pub mod feedforward;
pub mod hold;
pub mod param_change;
pub mod reference;
pub mod sense;

use crate::friction::FrictionModel;
use crate::{JointVec, N_JOINTS};

/// Why the core refuses a parameter set: which parameter, the value given and the rule it
/// breaks (the text a node returns as a parameter service's reason), or a model it cannot use.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ConfigError {
    #[error("{field} = {value} {rule}")]
    Invalid { field: String, value: String, rule: String },
    /// The robot model lacks what the controller needs.
    #[error("{0}")]
    Model(String),
}

impl From<ConfigError> for String {
    /// The message, where a caller reports errors as text (CLI, logs).
    fn from(e: ConfigError) -> String {
        e.to_string()
    }
}

impl ConfigError {
    /// `field = value rule`, e.g. `m_d[2] = -1 must be a positive finite mass`.
    pub fn invalid(field: impl Into<String>, value: impl std::fmt::Display, rule: impl Into<String>) -> Self {
        ConfigError::Invalid { field: field.into(), value: value.to_string(), rule: rule.into() }
    }
}


/// The whole pipeline: controller, friction feedforward and actuation limits.
#[derive(Clone, Debug)]
pub struct Pipeline<const N: usize = N_JOINTS> {
    pub controller: controller::Controller<N>,
    /// The friction feedforward model (`None`: no feedforward).
    pub friction: Option<FrictionModel>,
    pub actuate: actuate::ActuateParams<N>,
}

/// State of the whole pipeline.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PipelineState<const N: usize = N_JOINTS> {
    pub controller: controller::ControllerState<N>,
    pub actuate: actuate::ActuateState<N>,
}

/// Output of one cycle of the whole pipeline.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PipelineOutputs<const N: usize = N_JOINTS> {
    /// Torque to the drives [N·m].
    pub tau: JointVec<N>,
    /// The controller's torque and report.
    pub control: controller::ControlOutputs<N>,
    pub actuate: actuate::ActuateReport<N>,
}

impl<const N: usize> Pipeline<N> {
    pub fn initial_state(&self) -> PipelineState<N> {
        PipelineState { controller: self.controller.initial_state(), actuate: actuate::ActuateState::default() }
    }
}

/// One cycle of all five stages. Pure; `ws` is scratch memory.
pub fn step<const N: usize>(
    p: &Pipeline<N>,
    s: &PipelineState<N>,
    m: &sense::RawMeasurements<N>,
    r: &controller::Reference,
    ws: &mut controller::Workspace<N>,
) -> (PipelineState<N>, PipelineOutputs<N>) {
    let mut next = *s;
    let out = update(p, &mut next, m, r, ws);
    (next, out)
}

/// [`step`] on a state the caller keeps (this cycle's on entry, the next cycle's on return;
/// the same numbers, without copying the state in and out: [`controller::update`]).
pub fn update<const N: usize>(
    p: &Pipeline<N>,
    next: &mut PipelineState<N>,
    m: &sense::RawMeasurements<N>,
    r: &controller::Reference,
    ws: &mut controller::Workspace<N>,
) -> PipelineOutputs<N> {
    let control = controller::update(&p.controller, &mut next.controller, m, r, ws);
    // Friction feedforward only while the measurements are valid (not in the hold), at the
    // velocity the controller names (the measured one, or the scheduled law's blend with
    // the reference: feedforward.rs).
    let tau_ff = match (&p.friction, control.status.fault) {
        (Some(f), None) => feedforward::step(f, control.dq_ff.as_ref().unwrap_or(&control.dq), &control.tau),
        _ => control.tau,
    };
    let (as_, report) = actuate::step(&p.actuate, &next.actuate, &tau_ff);
    next.actuate = as_;
    PipelineOutputs { tau: report.tau, control, actuate: report }
}
