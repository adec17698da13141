//! Where the tip should go: a paper task's reference trajectory (`naic_core::task`, the
//! same presets `naic sim` runs), or none (the node then uses its start pose moved
//! `approach_depth` along the force axis).

use naic_core::{model::Model, pipeline::controller::Reference, task::{Task, TaskError}};

pub const SCENARIOS: [&str; 6] = ["none", "flat", "stiffness-step", "slope", "foam", "two-material"];
pub const DEFAULT_SCENARIO: &str = "flat";

/// A task's reference as a function of controller time.
#[derive(Clone)]
pub struct ScenarioReference {
    task: Task,
}

impl ScenarioReference {
    /// `None` for "none".
    pub fn new(name: &str, model: &Model) -> Result<Option<Self>, TaskError> {
        if name == "none" {
            return Ok(None);
        }
        let task = naic_core::task::preset(name, model)?;
        Ok(Some(ScenarioReference { task }))
    }

    /// The scenario `name` placed relative to the robot file's arm (its `start_q`;
    /// `naic_core::task::preset_relative`, as `naic sim --robot` places it). `None` for "none".
    pub fn for_robot(name: &str, robot: &naic_core::robot_file::Robot) -> Result<Option<Self>, TaskError> {
        if name == "none" {
            return Ok(None);
        }
        let Some(q) = robot.start_q.as_ref().filter(|q| q.len() == 6) else {
            return Err(TaskError::NoStartJoints { file: robot.file.display().to_string() });
        };
        let q0: [f64; 6] = std::array::from_fn(|i| q[i]);
        let task = naic_core::task::preset_relative(name, &robot.model, q0)?;
        Ok(Some(ScenarioReference { task }))
    }

    /// The reference at controller time `t` [s] (allocation-free).
    pub fn at(&self, t: f64) -> Reference {
        self.task.reference(t)
    }
}
