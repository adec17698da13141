//! The JK5 model and its Table 1 friction as the tests load them: one place for the unit
//! tests and the closed-loop test files (`tests/common`). Not part of the simulator's API.

use naic_core::friction::{FrictionModel, FrictionParams, Smoothing, DEFAULT_V_S};
use naic_core::model::Model;

/// The repository root, for the URDF and params files.
pub const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

/// The JK5 model of `urdf/jk5.urdf`.
pub fn model() -> Model {
    Model::from_urdf_file(format!("{ROOT}/urdf/jk5.urdf")).expect("urdf/jk5.urdf loads")
}

/// Table 1 friction (`params/friction_jk5.yaml`), tanh-smoothed as the simulator and the
/// feedforward use it.
pub fn table1_friction() -> FrictionModel {
    FrictionParams::from_yaml_file(format!("{ROOT}/params/friction_jk5.yaml"))
        .and_then(|p| p.to_model())
        .and_then(|m| m.with_smoothing(Smoothing::Tanh { v_s: DEFAULT_V_S }))
        .expect("params/friction_jk5.yaml loads")
}
