//! The controllers the simulator runs: the core's whole pipeline
//! (`naic_core::pipeline::step` — sense → estimate → control → friction
//! feedforward with the identified model → actuation guard), configured with
//! a scenario's settings. Nothing of the control law lives here.

use crate::runner::Controller as SimController;
use crate::scenario::Scenario;
use naic_core::friction::FrictionModel;
use naic_core::model::Model;
use naic_core::pipeline::actuate::ActuateParams;
use naic_core::pipeline::control::force_law::Mode;
use naic_core::pipeline::control::ForceAxis;
use naic_core::pipeline::controller::{Controller, ControllerParams, Reference, Status, Workspace};
use naic_core::pipeline::estimate::ToolParams;
use naic_core::pipeline::feedforward::FastVelocity;
use naic_core::pipeline::{self, param_change, ConfigError, Pipeline, PipelineState};
use naic_core::pipeline::sense::RawMeasurements;
use naic_core::{JointVec, N_JOINTS};
use nalgebra::Vector3;

/// Settings of the simulated controller that the paper does not fix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoopSettings {
    /// NAIC learning rate γ requested (clipped to the eq-15 bound each cycle).
    pub gamma: f64,
    /// NAIC σ margin (fraction of the force-loop stability limit); ∞ = the law as written.
    pub sigma_margin: f64,
    /// Median window on the joint velocity (the paper median-filters it, §5.1).
    pub median_window: usize,
    /// Free-space samples for the F/T tare at start.
    pub tare_samples: u32,
    /// Contact detection thresholds [N]: enter (the paper's laws), enter (the scheduled law
    /// and `oracle`, `ContactDetect::scheduled_enter_n`), exit.
    pub contact_enter_n: f64,
    pub scheduled_contact_enter_n: f64,
    pub contact_exit_n: f64,
    /// Safety force limit [N]: above it the controller retracts (`inf` disables).
    pub force_limit_n: f64,
    /// Sensor-to-torque delay of the loop in control periods (0 = the in-process
    /// loop; 1–2 = the DDS chain): the controller sees the measurements of `d` periods ago.
    pub delay_cycles: usize,
    /// The controller's dynamic model is the plant's with every mass and inertia scaled by this.
    pub model_mass_error: f64,
    /// The F/T tare takes readings at rest only and holds the arm meanwhile
    /// (`ControllerParams::tare_at_rest`, the node's default; `naic sim --tare at-rest`).
    /// Off: the first samples while the arm starts moving (on a sensor that reads the tool's
    /// inertial wrench, with [`Self::sensor_reads_tool_inertia`] so that its inertial force is no bias).
    pub tare_at_rest: bool,
    /// The sensor reads the tool's inertial force, and the tare takes the force the model
    /// predicts from the tool's motion out of its samples, and the contact decisions take it
    /// out of the contact force (`ControllerParams::sensor_reads_tool_inertia`): on MuJoCo and
    /// with `--inertial-wrench`. Off: the own plant's sensor, which reads none.
    pub sensor_reads_tool_inertia: bool,
    /// The derived law's parts (`naic sim --ablate`: all on but the ones an ablation study
    /// turns off).
    pub derived_parts: naic_core::pipeline::control::derived::DerivedParts,
}

/// The largest `delay_cycles` the simulated loop supports.
pub const MAX_DELAY_CYCLES: usize = 4;

/// The controllers of `naic sim --controller`: the core's modes, plus the benchmark-only
/// `oracle` (the scheduled law with the simulator's true k_e instead of its estimate) and
/// `derived_oracle` (the derived law with it: `k̂ = k̄ = k_low` = the true k_e).
pub const CONTROLLERS: [&str; 7] = ["naic", "aic", "fixed", "scheduled", "oracle", "derived", "derived_oracle"];

/// The oracle form of a law by its `naic sim` name: `(mode, oracle)`.
fn mode_of(name: &str) -> Result<(Mode, bool), ConfigError> {
    Ok(match name {
        "oracle" => (Mode::Scheduled, true),
        "derived_oracle" => (Mode::Derived, true),
        other => (Mode::parse(other)?, false),
    })
}

impl Default for LoopSettings {
    fn default() -> Self {
        Self {
            gamma: naic_core::pipeline::control::force_law::DEFAULT_GAMMA,
            sigma_margin: 0.5,
            median_window: 5,
            tare_samples: 100,
            contact_enter_n: 1.0,
            scheduled_contact_enter_n: naic_core::pipeline::control::SCHEDULED_CONTACT_ENTER_N,
            contact_exit_n: 0.2,
            force_limit_n: 50.0,
            delay_cycles: 0,
            model_mass_error: 1.0,
            tare_at_rest: false,
            sensor_reads_tool_inertia: false,
            derived_parts: naic_core::pipeline::control::derived::DerivedParts::ALL,
        }
    }
}


/// The core pipeline + friction feedforward + actuation, as the simulator drives it.
#[derive(Clone)]
pub struct PipelineController<const N: usize = N_JOINTS> {
    name: String,
    pipeline: Pipeline<N>,
    state: PipelineState<N>,
    ws: Workspace<N>,
    /// The scheduled law is given the true stiffness (the `oracle` benchmark).
    oracle: bool,
    /// The last `delay + 1` measurements, newest first.
    delayed: [Option<RawMeasurements<N>>; MAX_DELAY_CYCLES + 1],
    delay: usize,
}

impl<const N: usize> PipelineController<N> {
    /// The controller `mode` with the scenario's impedance settings, the
    /// force axis of the scenario, and `friction` as feedforward (None: off).
    pub fn new(
        mode: Mode,
        scenario: &Scenario<N>,
        model: &Model,
        friction: Option<FrictionModel>,
        tool_mass: f64,
        tool_com: Vector3<f64>,
        settings: &LoopSettings,
    ) -> Result<Self, ConfigError> {
        if settings.delay_cycles > MAX_DELAY_CYCLES {
            return Err(ConfigError::invalid("delay_cycles", settings.delay_cycles, format!("must be at most {MAX_DELAY_CYCLES}")));
        }
        let f = settings.model_mass_error;
        if !(f > 0.0 && f.is_finite()) {
            return Err(ConfigError::invalid("model mass error", f, "must be a positive factor (1 = exact model)"));
        }
        let model = &if f == 1.0 { model.clone() } else { model.with_scaled_inertias(f) };
        let force_axis = ForceAxis::new(scenario.task.force_axis)?;
        // The paper's settings on this model, then what the scenario and the loop settings change.
        let gamma = if mode == Mode::Naic { settings.gamma } else { 0.0 };
        let mut params = ControllerParams::paper_defaults(model, mode, gamma);
        params.sense.median_window = settings.median_window;
        params.tool = ToolParams { mass: tool_mass, com: tool_com, gravity: model.gravity, ..params.tool };
        params.tare_samples = settings.tare_samples;
        params.tare_at_rest = settings.tare_at_rest;
        params.sensor_reads_tool_inertia = settings.sensor_reads_tool_inertia;
        let imp = &scenario.task.impedance;
        let c = &mut params.control;
        c.impedance = imp.params;
        c.force_axis = force_axis;
        c.force_law.sigma = imp.sigma;
        c.force_law.lambda = scenario.task.dt;
        c.force_law.sigma_margin = settings.sigma_margin;
        c.contact.enter_n = settings.contact_enter_n;
        c.contact.scheduled_enter_n = settings.scheduled_contact_enter_n;
        c.contact.exit_n = settings.contact_exit_n;
        c.force_limit.limit_n = settings.force_limit_n;
        c.force_law.integral_limit_n = settings.force_limit_n;
        if mode == Mode::Derived {
            // The task's expected surface, and the loop delay the gains are designed for.
            c.force_law.scheduled.approach.expected_surface = scenario.task.expected_surface;
            c.force_law.derived.delay_cycles = settings.delay_cycles as f64;
            c.force_law.derived.parts = settings.derived_parts;
        }
        if mode == Mode::Scheduled {
            // The task's expected surface (acrylic, two-material): the approach slows down near it.
            c.force_law.scheduled.approach.expected_surface = scenario.task.expected_surface;
            // The friction feedforward on the unfiltered velocity in contact where a joint's
            // law falls with speed, led by 2 periods on stiff surfaces
            // (naic_core::pipeline::feedforward::FastVelocity): the drops are the feedforward model's.
            c.force_law.scheduled.friction_fast = friction.as_ref().map(FastVelocity::for_model);
        }
        let mut effort = [0.0; N];
        for (e, j) in effort.iter_mut().zip(model.joints()) {
            *e = j.limits.effort;
        }
        let controller = Controller::new(model.clone(), params)?;
        let ws = controller.workspace();
        let pipeline = Pipeline {
            controller,
            friction,
            actuate: ActuateParams { effort_limit: effort, max_delta: [f64::INFINITY; N] },
        };
        let state = pipeline.initial_state();
        let delayed = [None; MAX_DELAY_CYCLES + 1];
        Ok(Self { name: mode.as_str().to_string(), pipeline, state, ws, oracle: false, delayed, delay: settings.delay_cycles })
    }

    /// A controller by its `naic sim` name (one of [`CONTROLLERS`]).
    pub fn by_name(
        name: &str,
        scenario: &Scenario<N>,
        model: &Model,
        friction: Option<FrictionModel>,
        tool: (f64, Vector3<f64>),
        settings: &LoopSettings,
    ) -> Result<Self, ConfigError> {
        let (mode, oracle) = mode_of(name)?;
        let mut c = Self::new(mode, scenario, model, friction, tool.0, tool.1, settings)?;
        c.oracle = oracle;
        if oracle {
            c.name = name.into();
        }
        Ok(c)
    }
}

impl<const N: usize> PipelineController<N> {
    /// The controller's parameters now.
    pub fn params(&self) -> &ControllerParams<N> {
        self.pipeline.controller.params()
    }

    /// The pipeline's state after the last step (read-only: traces of the law's internals,
    /// e.g. `examples/contact_trace.rs`).
    pub fn state(&self) -> &naic_core::pipeline::PipelineState<N> {
        &self.state
    }

    /// Change the parameters mid-run by the node's policy
    /// (`naic_core::pipeline::param_change`: the NAIC weights restart when the force law or
    /// impedance changed; a force-limit retraction is kept). Not in the 1 kHz path.
    pub fn set_params(&mut self, new: ControllerParams<N>) -> Result<param_change::Outcome, ConfigError> {
        let (c, s, outcome) = param_change::apply(&self.pipeline.controller, &self.state.controller, new)?;
        self.pipeline.controller = c;
        self.state.controller = s;
        Ok(outcome)
    }
}

/// A [`PipelineController`] that calls `after` with itself and its status after every step:
/// traces of a law's internal state (`examples/contact_trace.rs`, `examples/derived_trace.rs`).
pub struct Observed<'a, F, const N: usize = N_JOINTS> {
    pub inner: &'a mut PipelineController<N>,
    pub after: F,
}

impl<const N: usize, F: FnMut(&PipelineController<N>, &Status)> SimController<N> for Observed<'_, F, N> {
    fn name(&self) -> &str {
        self.inner.name()
    }

    fn set_true_stiffness(&mut self, k_e: f64) {
        self.inner.set_true_stiffness(k_e)
    }

    fn step(&mut self, m: &RawMeasurements<N>, r: &Reference) -> (JointVec<N>, Status) {
        let (tau, st) = self.inner.step(m, r);
        (self.after)(self.inner, &st);
        (tau, st)
    }
}

impl<const N: usize> SimController<N> for PipelineController<N> {
    fn name(&self) -> &str {
        &self.name
    }

    fn set_true_stiffness(&mut self, k_e: f64) {
        if self.oracle && k_e > 0.0 {
            self.state.controller.control.sched.k_known = Some(k_e);
        }
    }

    fn step(&mut self, m: &RawMeasurements<N>, r: &Reference) -> (JointVec<N>, Status) {
        // The loop delay: the controller works on the measurement of `delay` periods ago.
        self.delayed.rotate_right(1);
        self.delayed[0] = Some(*m);
        let m = &self.delayed[..=self.delay].iter().rev().find_map(|x| *x).unwrap_or(*m);
        let out = pipeline::update(&self.pipeline, &mut self.state, m, r, &mut self.ws);
        (out.tau, out.control.status)
    }
}
