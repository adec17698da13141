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

    /// The reference at controller time `t` [s] (allocation-free).
    pub fn at(&self, t: f64) -> Reference {
        self.task.reference(t)
    }
}
