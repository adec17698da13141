//! Where the tip should go: a `naic_sim` paper scenario's reference trajectory, or none
//! (the node then uses its start pose moved `approach_depth` along the force axis).

use naic_core::{model::Model, pipeline::controller::Reference};

pub const SCENARIOS: [&str; 6] = ["none", "flat", "stiffness-step", "slope", "foam", "two-material"];
pub const DEFAULT_SCENARIO: &str = "flat";

/// A scenario's reference as a function of controller time.
#[derive(Clone)]
pub struct ScenarioReference {
    scenario: naic_sim::scenario::Scenario,
}

impl ScenarioReference {
    /// `None` for "none".
    pub fn new(name: &str, model: &Model) -> Result<Option<Self>, String> {
        if name == "none" {
            return Ok(None);
        }
        let scenario = naic_sim::scenario::preset(name, model).map_err(|e| format!("scenario '{name}': {e}"))?;
        Ok(Some(ScenarioReference { scenario }))
    }

    /// The reference at controller time `t` [s] (allocation-free).
    pub fn at(&self, t: f64) -> Reference {
        self.scenario.reference(t)
    }
}
