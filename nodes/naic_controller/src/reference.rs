//! Where the tip should go: a paper task's reference trajectory (`naic_core::task`, the
//! same presets `naic sim` runs), or none (the node then uses its start pose moved
//! `approach_depth` along the force axis).

use naic_core::{model::Model, pipeline::controller::Reference, task::{Task, TaskError}};

pub const SCENARIOS: [&str; 6] = ["none", "flat", "stiffness-step", "slope", "foam", "two-material"];
pub const DEFAULT_SCENARIO: &str = "flat";

/// A task's reference as a function of controller time (any joint count: the task's start
/// joints are the simulator's, the reference is Cartesian).
#[derive(Clone)]
pub struct ScenarioReference {
    reference: std::sync::Arc<dyn Fn(f64) -> Reference + Send + Sync>,
}

impl ScenarioReference {
    fn of<const N: usize>(task: Task<N>) -> Self {
        ScenarioReference { reference: std::sync::Arc::new(move |t| task.reference(t)) }
    }
}

impl ScenarioReference {
    /// `None` for "none".
    pub fn new(name: &str, model: &Model) -> Result<Option<Self>, TaskError> {
        if name == "none" {
            return Ok(None);
        }
        Ok(Some(Self::of(naic_core::task::preset(name, model)?)))
    }

    /// The scenario `name` placed relative to the robot file's arm (its `start_q`;
    /// `naic_core::task::preset_relative`, as `naic sim --robot` places it). `None` for "none".
    pub fn for_robot<const N: usize>(name: &str, robot: &naic_core::robot_file::Robot) -> Result<Option<Self>, TaskError> {
        if name == "none" {
            return Ok(None);
        }
        let Some(q) = robot.start_q.as_ref().filter(|q| q.len() == N) else {
            return Err(TaskError::NoStartJoints { file: robot.file.display().to_string() });
        };
        let q0: [f64; N] = std::array::from_fn(|i| q[i]);
        Ok(Some(Self::of(naic_core::task::preset_relative::<N>(name, &robot.model, q0)?)))
    }

    /// The reference at controller time `t` [s] (allocation-free).
    pub fn at(&self, t: f64) -> Reference {
        (self.reference)(t)
    }
}
