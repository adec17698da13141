//! Scenario presets: the paper's simulations (§4.1 flat, eq 22 stiffness
//! steps, §4.2 slope) and its two real-world experiments (§5.2.1 foam,
//! §5.2.2 acrylic + foam) rebuilt in simulation. A [`Scenario`] is a
//! [`naic_core::task::Task`] — what the controller is asked to do: start joints,
//! reference, `f_d`, impedance; the trajectory facts are documented there — put
//! on a simulated surface: environment, plant seed, phase events for the metrics.
//!
//! Facts and where they come from:
//! * §4.1: the surface (height in the task) has k_e = 2000 N/m (the authors'
//!   MJCF `solref="-2000 -0.1"`).
//! * eq 22: k_e = 2000 → 5000 → 2000 N/m at t = 2 s and 4 s.
//! * §4.2 slope (our choice, the paper gives no angle): a plane through the
//!   paper's contact point — height 0.124 m at the x the reference has at the
//!   paper's contact time 0.621 s (x = −0.3 − 0.09·0.621 = −0.356 m) — falling
//!   towards −x so that it meets the §4.1 table height 0.08 m at the end of
//!   the path x = −0.75 m: slope 0.044 m / 0.394 m, θ = 6.37°.
//! * §5.2.1: foam at the task's surface height.
//! * §5.2.2 two materials: acrylic under the start point, foam beyond
//!   x_boundary = start − 0.03 m.
//!
//! Materials (our choice, the paper gives no numbers):
//! * Foam: k_e = 1000 N/m, b_e = 10 N·s/m. Reasoning: a flat punch of radius
//!   a on an elastic half-space has k = 2 E a / (1 − ν²); soft polyurethane
//!   foam has E ≈ 30–100 kPa and ν ≈ 0.3, a 10 mm rod tip (the MJCF tip
//!   sphere radius) gives k ≈ 700–2200 N/m. Damping: foam is lossy; 10 N·s/m
//!   gives a contact time constant b/k = 10 ms.
//! * Acrylic: k_e = 50 000 N/m, b_e = 50 N·s/m. PMMA itself (E ≈ 3 GPa)
//!   would give ~10⁸ N/m at the rod tip; what the arm feels is the plate and
//!   its support in series, which for a thin plate on a bench we take as
//!   5·10⁴ N/m (25× the §4.1 value) — "hard" relative to the foam, as the
//!   paper describes it. The value is a modelling choice, not a measurement.

use crate::environment::{Environment, Material, MaterialMap};
use crate::metrics::{PhaseSpec, PhaseStart};
use naic_core::model::Model;
use naic_core::N_JOINTS;
use naic_core::task::{self, Task, TaskError};
use nalgebra::{Unit, Vector3};

/// The task side, where it always was for the users of `naic_sim::scenario`.
pub use naic_core::task::{deg, inverse_kinematics, tip_pose, ImpedanceSettings, Ramp, PAPER_IMPEDANCE, Q0_FLAT_DEG};

/// The scenario names of `naic sim --scenario`: one per task preset.
pub const SCENARIOS: [&str; 6] = task::PRESETS;

/// One sample of the reference (tip pose, twist and acceleration targets, base frame,
/// and `f_d`): the controller's own [`Reference`], one type for the simulator and the nodes.
pub use naic_core::pipeline::controller::Reference;

/// A complete scenario: a paper task on a simulated surface.
#[derive(Clone, Debug)]
pub struct Scenario<const N: usize = N_JOINTS> {
    /// What the controller is asked to do (name, duration, control period, start joints,
    /// reference, `f_d`, impedance).
    pub task: Task<N>,
    pub description: String,
    pub env: Environment,
    /// RNG seed of the plant (noise, sensor bias).
    pub seed: u64,
    /// What the paper reports for this scenario (for the README comparison).
    pub paper_notes: String,
}

/// Why `--stiffness` cannot be applied.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ScenarioError {
    #[error("stiffness {k_e} N/m must be a positive number")]
    Stiffness { k_e: f64 },
    #[error("scenario '{scenario}' has two materials: --stiffness applies to one-material scenarios")]
    TwoMaterials { scenario: String },
}

impl From<ScenarioError> for String {
    /// The message, where a caller reports errors as text (CLI, logs).
    fn from(e: ScenarioError) -> String {
        e.to_string()
    }
}

impl<const N: usize> Scenario<N> {
    /// Desired force at time `t` (the task's).
    pub fn f_d(&self, t: f64) -> f64 {
        self.task.f_d(t)
    }

    /// Reference at time `t` (the task's; allocation-free).
    pub fn reference(&self, t: f64) -> Reference {
        self.task.reference(t)
    }

    /// Phase events after t = 0 for the metrics: desired-force steps and
    /// stiffness switches (the first phase, from first contact, is added by
    /// [`crate::metrics::controller_metrics`]).
    pub fn events(&self) -> Vec<PhaseSpec> {
        let mut ev: Vec<PhaseSpec> = Vec::new();
        for w in self.task.f_d_steps.windows(2) {
            ev.push(PhaseSpec { t_start: w[1].0, desired_force: w[1].1, start: PhaseStart::ForceStep { from: w[0].1 } });
        }
        if let MaterialMap::StiffnessSchedule { switches, .. } = &self.env.material {
            for &(t, _) in switches {
                ev.push(PhaseSpec { t_start: t, desired_force: self.f_d(t), start: PhaseStart::Disturbance });
            }
        }
        ev.sort_by(|a, b| a.t_start.total_cmp(&b.t_start));
        ev
    }

    /// The same scenario on a surface of stiffness `k_e` (`naic sim --stiffness`): a
    /// uniform surface gets `k_e`; a stiffness schedule (eq 22) is scaled so that its
    /// first value is `k_e`. The two-material surface has no single stiffness: an error.
    pub fn with_stiffness(&self, k_e: f64) -> Result<Scenario<N>, ScenarioError> {
        if !(k_e > 0.0 && k_e.is_finite()) {
            return Err(ScenarioError::Stiffness { k_e });
        }
        let mut s = self.clone();
        match &mut s.env.material {
            MaterialMap::Uniform(m) => m.k_e = k_e,
            MaterialMap::StiffnessSchedule { base, switches } => {
                let f = k_e / base.k_e;
                base.k_e = k_e;
                for sw in switches.iter_mut() {
                    sw.1 *= f;
                }
            }
            MaterialMap::SplitX { .. } => return Err(ScenarioError::TwoMaterials { scenario: s.task.name.clone() }),
        }
        s.description = format!("{} (stiffness overridden: k_e = {k_e} N/m)", s.description);
        Ok(s)
    }

    /// Number of control steps.
    pub fn steps(&self) -> usize {
        self.task.steps()
    }
}

/// The plant of a scenario: its environment and control period, joint
/// `friction` (tanh-smoothed model, or `None`), the implicit-friction
/// integrator with sub-steps for the stiffest contact, the SI-145-5 sensor
/// with the given tool (mass, COM in the sensor frame; see
/// [`crate::sensor::tool_from_urdf`]) and its bias drawn from the scenario
/// seed, and the default encoders.
pub fn plant_for<const N: usize>(
    s: &Scenario<N>,
    model: Model,
    friction: Option<naic_core::friction::FrictionModel>,
    tool: (f64, Vector3<f64>),
) -> Result<crate::plant::PlantParams<N>, crate::plant::PlantError> {
    let mut rng = crate::rng::Rng::seed(s.seed ^ 0x005E_EDF7);
    let ft = crate::sensor::Mini45::si_145_5(tool.0, tool.1, &mut rng);
    let mut p = crate::plant::PlantParams::new(
        model,
        friction,
        crate::plant::Integrator::ImplicitFriction,
        s.task.dt,
        1,
        s.env.clone(),
        ft,
        crate::sensor::Encoders::default(),
    )?;
    p.substeps = p.substeps_for_contact(&s.task.q0, s.task.dt);
    Ok(p)
}

fn foam() -> Material {
    Material { k_e: 1000.0, b_e: 10.0, mu: 0.0 }
}
fn acrylic() -> Material {
    Material { k_e: 50_000.0, b_e: 50.0, mu: 0.0 }
}

/// Build a scenario preset by name with the given robot model: the task preset
/// ([`naic_core::task::preset`]) on its surface.
pub fn preset(name: &str, model: &Model) -> Result<Scenario, TaskError> {
    let task = task::preset(name, model)?;
    let k_paper = Material { k_e: 2000.0, b_e: 0.0, mu: 0.0 };
    let z = task.surface;
    let (description, env, paper_notes) = match name {
        "flat" => (
            "§4.1: flat surface z = 0.08 m, k_e = 2000 N/m, f_d = 10 N then 20 N at t = 3 s".into(),
            Environment::horizontal(z, MaterialMap::Uniform(k_paper)),
            "Fig 2: contact at t = 0.7 s; NAIC converges faster and with less oscillation than AIC",
        ),
        "acrylic" => (
            "§4.1 approach onto acrylic (k_e = 50 000 N/m, b_e = 50 N·s/m, our choice) at z = 0.08 m, f_d = 10 N".into(),
            Environment::horizontal(z, MaterialMap::Uniform(acrylic())),
            "not in the paper: the hard surface of §5.2.2 with the §4.1 approach and target (issue 12)",
        ),
        "stiffness-step" => (
            "eq 22: flat surface z = 0.08 m, k_e = 2000 → 5000 → 2000 N/m at t = 2 s and 4 s, f_d = 10 N".into(),
            Environment::horizontal(z, MaterialMap::StiffnessSchedule { base: k_paper, switches: vec![(2.0, 5000.0), (4.0, 2000.0)] }),
            "Fig 3: after the step at 2 s NAIC quickly converges, AIC oscillates substantially",
        ),
        "slope" => {
            let x_c = task.ramp.from.x - 0.09 * 0.621;
            let (z_c, z_end, x_end): (f64, f64, f64) = (0.124, z, task.ramp.to.x);
            let slope = (z_c - z_end) / (x_c - x_end);
            let normal = Unit::new_normalize(Vector3::new(-slope, 0.0, 1.0));
            (
                format!(
                    "§4.2: plane through (x = {x_c:.3} m, z = 0.124 m) falling towards −x by {:.2}° (our choice), k_e = 2000 N/m, f_d = 10 N",
                    slope.atan().to_degrees()
                ),
                Environment { point: Vector3::new(x_c, 0.0, z_c), normal, material: MaterialMap::Uniform(k_paper), v_slip: 1e-3, enabled: true },
                "Fig 4: contact at Z = 0.124 m at t = 0.621 s; NAIC tracks more quickly and smoothly than AIC",
            )
        }
        "foam" => (
            "§5.2.1: foam (k_e = 1000 N/m, b_e = 10 N·s/m, our choice) at z = 0.3813 m, start 0.538 m, f_d = −10 N in the sensor frame (10 N pushing)".into(),
            Environment::horizontal(z, MaterialMap::Uniform(foam())),
            "Fig 7: contact at t = 2.826 s; NAIC tracks −10 N",
        ),
        "two-material" => {
            let x_boundary = task.ramp.from.x - 0.03;
            (
                format!(
                    "§5.2.2: acrylic (k_e = 50000 N/m) for x ≥ {x_boundary:.2} m, foam (1000 N/m) beyond, surface z = 0.3648 m, f_d = −3 N in the sensor frame; x target moves 0.06 m towards −x from t = 5 s"
                ),
                Environment::horizontal(z, MaterialMap::SplitX { x_boundary, high_x: acrylic(), low_x: foam() }),
                "Fig 8: contact with acrylic at 3.327 s with an impact, converged to −3 N before 4.756 s; a force jump when moving onto the foam, then tracks",
            )
        }
        // A task preset this module puts on no surface yet.
        other => return Err(TaskError::UnknownPreset { name: other.to_string() }),
    };
    Ok(Scenario { task, description, env, seed: 1, paper_notes: paper_notes.into() })
}

/// A scenario placed relative to the arm (issue 37): the task of
/// [`naic_core::task::preset_relative`] (start joints `q0`, the surface beyond the start tip
/// along the tool's axis, the path across the front of the arm) on the preset's materials:
/// `flat`, `acrylic`, `stiffness-step` and `foam` as for the JK5; `slope` a plane through
/// the point 0.044 m above the table where the path is at t = 0.621 s, falling along the path
/// to the table height at its end (the JK5's §4.2 plane, measured along the path).
/// `two-material` is not placed relative to the arm yet (an error).
pub fn preset_relative<const N: usize>(name: &str, model: &Model, q0: naic_core::JointVec<N>) -> Result<Scenario<N>, TaskError> {
    if name == "two-material" {
        return Err(TaskError::UnknownPreset { name: "two-material (placed for the JK5 only: its material boundary is a plane x = const of the JK5 table)".into() });
    }
    let task = task::preset_relative(name, model, q0)?;
    let k_paper = Material { k_e: 2000.0, b_e: 0.0, mu: 0.0 };
    let n = task.force_axis;
    // The plane through the surface point under the path's start, facing the tool (normal −n).
    let surface_point = task.ramp.from - n * task::relative::TARGET_DEPTH;
    let plane = |material: MaterialMap| Environment { point: surface_point, normal: Unit::new_normalize(-n), material, v_slip: 1e-3, enabled: true };
    let at = |p: &Vector3<f64>| format!("({:.3}, {:.3}, {:.3}) m", p.x, p.y, p.z);
    let (description, env) = match name {
        "flat" => (format!("§4.1 relative to the arm: surface through {}, normal {:?}, k_e = 2000 N/m, f_d = 10 N then 20 N at t = 3 s", at(&surface_point), -n), plane(MaterialMap::Uniform(k_paper))),
        "acrylic" => (format!("acrylic (k_e = 50 000 N/m) through {}, f_d = 10 N", at(&surface_point)), plane(MaterialMap::Uniform(acrylic()))),
        "stiffness-step" => (
            format!("eq 22 relative to the arm: surface through {}, k_e = 2000 → 5000 → 2000 N/m at 2 s and 4 s, f_d = 10 N", at(&surface_point)),
            plane(MaterialMap::StiffnessSchedule { base: k_paper, switches: vec![(2.0, 5000.0), (4.0, 2000.0)] }),
        ),
        "foam" => (format!("§5.2.1 relative to the arm: foam through {}, f_d = 10 N", at(&surface_point)), plane(MaterialMap::Uniform(foam()))),
        "slope" => {
            let t_hat = (task.ramp.to - task.ramp.from).normalize();
            let s_c = 0.09 * 0.621;
            let rise = 0.124 - 0.08;
            let slope = rise / (task::relative::PATH_LENGTH - s_c);
            let point = surface_point + t_hat * s_c - n * rise;
            let normal = Unit::new_normalize(-n + t_hat * slope);
            (
                format!("§4.2 relative to the arm: plane through {} falling along the path by {:.2}°, k_e = 2000 N/m, f_d = 10 N", at(&point), slope.atan().to_degrees()),
                Environment { point, normal, material: MaterialMap::Uniform(k_paper), v_slip: 1e-3, enabled: true },
            )
        }
        other => return Err(TaskError::UnknownPreset { name: other.to_string() }),
    };
    Ok(Scenario { task, description, env, seed: 1, paper_notes: "placed relative to the arm (issue 37): no paper figure".into() })
}

/// The robot file's F/T sensor model on a plant: each of range, resolution and noise the
/// file gives replaces the ATI mini45's (nothing given: nothing changes).
pub fn apply_sensor_spec<const N: usize>(p: &mut crate::plant::PlantParams<N>, spec: &naic_core::robot_file::SensorSpec) {
    if let Some(r) = spec.range {
        p.ft.range = r;
    }
    if let Some(r) = spec.resolution {
        p.ft.resolution = r;
    }
    if let Some(r) = spec.noise {
        p.ft.noise_sigma = r;
    }
}
