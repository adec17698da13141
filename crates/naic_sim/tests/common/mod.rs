//! Shared by the closed-loop test files: the JK5 model and its Table 1 friction.

use naic_core::friction::{FrictionModel, FrictionParams, Smoothing, DEFAULT_V_S};
use naic_core::model::Model;

pub const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

pub fn model() -> Model {
    Model::from_urdf_file(format!("{ROOT}/urdf/jk5.urdf")).unwrap()
}

/// Table 1 friction, tanh-smoothed as the simulator and the feedforward use it.
pub fn friction() -> FrictionModel {
    FrictionParams::from_yaml_file(format!("{ROOT}/params/friction_jk5.yaml"))
        .unwrap()
        .to_model()
        .unwrap()
        .with_smoothing(Smoothing::Tanh { v_s: DEFAULT_V_S })
        .unwrap()
}
