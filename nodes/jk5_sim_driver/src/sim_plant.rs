//! The driver's simulator: `naic_sim`'s JK5 + ATI mini45 (`SimArm`) in a paper scenario.

use naic_core::{
    friction::{FrictionParams, Smoothing},
    model::{Data6, Model},
    pipeline::hold,
};
use naic_sim::{arm::SimArm, scenario, sensor::tool_from_urdf};

use crate::plant::Plant;

/// Which simulator the driver runs (the read-only `plant` parameter).
pub const PLANT_NAME: &str = "naic_sim";

const FRICTION_FIX: &str = "set -p friction_file:=PATH, e.g. params/friction_jk5.yaml";

/// The plant of scenario `scenario` (naic_sim presets) on `urdf`, with the friction of
/// `friction_file` (tanh-smoothed with `v_s`) acting on the joints, at period `1/rate`.
pub fn make_plant(p: &naic_ros::ParamView) -> Result<SimPlant, String> {
    let (urdf, name, friction_file) = (p.str("urdf"), p.str("scenario"), p.str("friction_file"));
    let model = Model::from_urdf_file(urdf).map_err(|e| format!("robot model '{urdf}': {e} (set -p urdf:=PATH)"))?;
    let mut scen = scenario::preset(name, &model).map_err(|e| format!("scenario '{name}' on robot model '{urdf}': {e} (set -p urdf:=PATH)"))?;
    scen.dt = 1.0 / p.f64("rate");
    let friction = FrictionParams::from_yaml_file(friction_file)
        .and_then(|f| f.to_model())
        .and_then(|m| m.with_smoothing(Smoothing::Tanh { v_s: p.f64("friction_smoothing") }))
        .map_err(|e| format!("friction_file '{friction_file}': {e} ({FRICTION_FIX})"))?;
    if friction.n_joints() != 6 {
        return Err(format!("friction_file '{friction_file}' has {} joints; the JK5 needs 6 ({FRICTION_FIX})", friction.n_joints()));
    }
    let tool = tool_from_urdf(std::path::Path::new(urdf)).map_err(|e| format!("{e} (set -p urdf:=PATH)"))?;
    let params = scenario::plant_for(&scen, model, Some(friction), tool)
        .map_err(|e| format!("robot model '{urdf}' in scenario '{name}': {e} (set -p urdf:=PATH)"))?;
    let data = Data6::try_new(&params.model).map_err(|e| format!("robot model '{urdf}': {e}"))?;
    let dt = scen.dt;
    Ok(SimPlant { arm: SimArm::new(params, scen.q0, scen.seed), data, dt })
}

/// The simulated arm plus the workspace of the driver's hold.
pub struct SimPlant {
    arm: SimArm,
    data: Data6,
    /// Control period [s] (1/rate): the hold's damping is capped for stability at it.
    dt: f64,
}

impl Plant for SimPlant {
    fn step(&mut self, tau: &[f64; 6], _dt: f64) {
        self.arm.step(tau)
    }
    /// The core's hold law (`naic_core::pipeline::hold`) at the measured joint state, as a
    /// real driver would compute it from its encoders.
    fn hold_torque(&mut self, damping: f64) -> [f64; 6] {
        let (q, dq, _) = self.arm.joints();
        hold::torque(&self.arm.params().model, &mut self.data, &q, &dq, &[damping; 6], self.dt)
    }
    fn joints(&self) -> ([f64; 6], [f64; 6], [f64; 6]) {
        self.arm.joints()
    }
    fn wrench(&self) -> [f64; 6] {
        self.arm.wrench()
    }
    fn time(&self) -> f64 {
        self.arm.time()
    }
}
