//! The controllers the simulator runs: the core's whole pipeline
//! (`naic_core::pipeline::step` — sense → estimate → control → friction
//! feedforward with the identified model → actuation guard), configured with
//! a scenario's settings. Nothing of the control law lives here.

use crate::plant::Measurements;
use crate::runner::{ControlReport, Controller as SimController};
use crate::scenario::{ReferenceSample, Scenario};
use naic_core::dynamics::Damping;
use naic_core::friction::FrictionModel;
use naic_core::model::Model;
use naic_core::pipeline::actuate::ActuateParams;
use naic_core::pipeline::control::force_law::{ForceLawParams, Mode, WeightBounds};
use naic_core::pipeline::control::{ContactDetect, ControlParams, ForceAxis, ForceLimit, ImpedanceParams};
use naic_core::pipeline::controller::{Controller, ControllerParams, Reference, Workspace};
use naic_core::pipeline::estimate::ToolParams;
use naic_core::pipeline::{self, Pipeline, PipelineState};
use naic_core::pipeline::sense::{RawMeasurements, SenseParams};
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
    /// Contact detection thresholds [N].
    pub contact_enter_n: f64,
    pub contact_exit_n: f64,
    /// Safety force limit [N]: above it the controller retracts (`inf` disables).
    pub force_limit_n: f64,
}

impl Default for LoopSettings {
    fn default() -> Self {
        Self {
            gamma: 1e-4,
            sigma_margin: 0.5,
            median_window: 5,
            tare_samples: 100,
            contact_enter_n: 1.0,
            contact_exit_n: 0.2,
            force_limit_n: 50.0,
        }
    }
}

/// The core pipeline + friction feedforward + actuation, as the simulator drives it.
#[derive(Clone)]
pub struct PipelineController {
    name: String,
    pipeline: Pipeline,
    state: PipelineState,
    ws: Workspace,
}

impl PipelineController {
    /// The controller `mode` with the scenario's impedance settings, the
    /// force axis of the scenario, and `friction` as feedforward (None: off).
    pub fn new(
        mode: Mode,
        scenario: &Scenario,
        model: &Model,
        friction: Option<FrictionModel>,
        tool_mass: f64,
        tool_com: Vector3<f64>,
        settings: &LoopSettings,
    ) -> Result<Self, String> {
        let n = scenario.force_axis;
        let axis = (0..3).max_by(|&a, &b| n[a].abs().total_cmp(&n[b].abs())).unwrap_or(2);
        if (n.norm() - 1.0).abs() > 1e-9 || (n[axis].abs() - 1.0).abs() > 1e-9 {
            return Err(format!("the force axis {n:?} must be ±x, ±y or ±z of the base frame"));
        }
        let joints = model.joints();
        let mut q_min = [0.0; 6];
        let mut q_max = [0.0; 6];
        let mut dq_max = [0.0; 6];
        let mut effort = [0.0; 6];
        for i in 0..6 {
            q_min[i] = joints[i].limits.lower;
            q_max[i] = joints[i].limits.upper;
            dq_max[i] = 2.0 * joints[i].limits.velocity;
            effort[i] = joints[i].limits.effort;
        }
        let imp = &scenario.impedance;
        let params = ControllerParams {
            sense: SenseParams {
                q_min,
                q_max,
                q_margin: 0.1,
                dq_max,
                wrench_max: [217.5, 217.5, 435.0, 7.5, 7.5, 7.5],
                median_window: settings.median_window,
                joint_timeout: 0.01,
                wrench_timeout: 0.01,
            },
            tool: ToolParams { mass: tool_mass, com: tool_com, tip: Vector3::new(0.0, 0.0, 0.169), gravity: model.gravity },
            tare_samples: settings.tare_samples,
            control: ControlParams {
                impedance: ImpedanceParams { m_d: imp.m_d, b_d: imp.b_d, k_free: imp.k_free, k_contact: imp.k_contact },
                force_axis: ForceAxis { axis, sign: n[axis].signum() },
                force_law: ForceLawParams {
                    mode,
                    sigma: imp.sigma,
                    gamma: if mode == Mode::Naic { settings.gamma } else { 0.0 },
                    bounds: WeightBounds::default(),
                    lambda: scenario.dt,
                    sigma_margin: settings.sigma_margin,
                },
                contact: ContactDetect { enter_n: settings.contact_enter_n, exit_n: settings.contact_exit_n, exit_cycles: 0 },
                force_limit: ForceLimit { limit_n: settings.force_limit_n, retract_speed: 0.02, retract_cycles: 500 },
            },
            hold_damping: [5.0; 6],
            damping: Damping::default(),
        };
        let controller = Controller::new(model.clone(), params)?;
        let ws = controller.workspace();
        let pipeline = Pipeline {
            controller,
            friction,
            actuate: ActuateParams { effort_limit: effort, max_delta: [f64::INFINITY; 6] },
        };
        let state = pipeline.initial_state();
        Ok(Self { name: mode.as_str().to_string(), pipeline, state, ws })
    }
}

impl SimController for PipelineController {
    fn name(&self) -> &str {
        &self.name
    }

    fn step(&mut self, m: &Measurements, r: &ReferenceSample) -> ControlReport {
        let raw = RawMeasurements { t: m.t, q: m.q, dq: m.dq, joints_stamp: m.t, wrench: m.wrench, wrench_stamp: m.t };
        let reference = Reference { p_d: r.p_d, r_d: r.r_d, v_d: r.v_d, a_d: r.a_d, f_d: r.f_d };
        let (state, out) = pipeline::step(&self.pipeline, &self.state, &raw, &reference, &mut self.ws);
        self.state = state;
        let st = &out.control.status;
        ControlReport {
            tau: out.tau,
            m_d: st.m_d,
            b_d: st.b_d,
            sigma: st.sigma,
            gamma: st.gamma,
            gamma_bound: st.gamma_bound,
            f_ext: st.f_ext,
            phase: st.phase as u8,
        }
    }
}
