//! Where the tip should go: a `naic_sim` paper scenario's reference trajectory (with the
//! feature `naic_sim_reference`), or none (the node then uses its start pose).

use naic_core::{model::Model, pipeline::controller::Reference};

pub const SCENARIOS: [&str; 6] = ["none", "flat", "stiffness-step", "slope", "foam", "two-material"];

#[cfg(feature = "naic_sim_reference")]
pub const DEFAULT_SCENARIO: &str = "flat";
#[cfg(not(feature = "naic_sim_reference"))]
pub const DEFAULT_SCENARIO: &str = "none";

/// A scenario's reference as a function of controller time.
pub struct ScenarioReference {
    #[cfg(feature = "naic_sim_reference")]
    scenario: naic_sim::scenario::Scenario,
    /// Without the feature the type has no values.
    #[cfg(not(feature = "naic_sim_reference"))]
    never: std::convert::Infallible,
}

impl ScenarioReference {
    /// `None` for "none"; an error naming the fix when scenarios are not built in.
    pub fn new(name: &str, _model: &Model) -> Result<Option<Self>, String> {
        if name == "none" {
            return Ok(None);
        }
        #[cfg(feature = "naic_sim_reference")]
        {
            let scenario = naic_sim::scenario::preset(name, _model).map_err(|e| format!("scenario '{name}': {e}"))?;
            Ok(Some(ScenarioReference { scenario }))
        }
        #[cfg(not(feature = "naic_sim_reference"))]
        Err(format!("scenario '{name}' needs naic_controller built with --features naic_sim_reference; use scenario:=none"))
    }

    /// The reference at controller time `t` [s] (allocation-free).
    #[cfg(feature = "naic_sim_reference")]
    pub fn at(&self, t: f64) -> Reference {
        let r = self.scenario.reference(t);
        Reference { p_d: r.p_d, r_d: r.r_d, v_d: r.v_d, a_d: r.a_d, f_d: r.f_d }
    }

    #[cfg(not(feature = "naic_sim_reference"))]
    pub fn at(&self, _t: f64) -> Reference {
        match self.never {}
    }
}
