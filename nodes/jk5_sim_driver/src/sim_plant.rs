//! The driver's simulator: `naic_sim`'s JK5 + ATI mini45 in a paper scenario.

use naic_core::{
    dynamics,
    friction::{FrictionParams, Smoothing},
    model::{Data6, Model},
};
use naic_sim::{
    plant::{self, Integrator, Observation, PlantParams, PlantState, PlantWorkspace},
    rng::Rng,
    scenario,
    sensor::{Encoders, Mini45},
};
use nalgebra::{Vector3, Vector6};

use crate::plant::Plant;

/// Tool beyond the sensor's measuring plane (authors' MJCF): mass [kg], CoM in the sensor frame [m].
const TOOL_MASS: f64 = 0.424;
const TOOL_COM_Z: f64 = 0.015;

pub struct SimPlant {
    p: PlantParams,
    s: PlantState,
    ws: PlantWorkspace,
    obs: Observation,
    data: Data6,
}

/// Which simulator the driver runs (the read-only `plant` parameter).
pub const PLANT_NAME: &str = "naic_sim";

impl SimPlant {
    /// The plant of scenario `name` (naic_sim presets) on `urdf`, with the friction of
    /// `friction_file` (tanh-smoothed with `v_s`) acting on the joints, at period `dt`.
    pub fn new(urdf: &str, name: &str, friction_file: &str, v_s: f64, dt: f64) -> Result<Self, String> {
        let model = Model::from_urdf_file(urdf).map_err(|e| format!("robot model '{urdf}': {e}"))?;
        let scen = scenario::preset(name, &model).map_err(|e| format!("scenario '{name}': {e}"))?;
        let friction = FrictionParams::from_yaml_file(friction_file)
            .and_then(|f| f.to_model())
            .and_then(|m| m.with_smoothing(Smoothing::Tanh { v_s }))
            .map_err(|e| format!("friction_file '{friction_file}': {e}"))?;
        let mut rng = Rng::seed(scen.seed ^ 0x005E_EDF7);
        let ft = Mini45::si_145_5(TOOL_MASS, Vector3::new(0.0, 0.0, TOOL_COM_Z), &mut rng);
        let data = Data6::try_new(&model).map_err(|e| format!("{urdf}: {e}"))?;
        let mut p = PlantParams::new(model, Some(friction), Integrator::ImplicitFriction, dt, 1, scen.env.clone(), ft, Encoders::default())
            .map_err(|e| e.to_string())?;
        p.substeps = p.substeps_for_contact(&scen.q0, dt);
        let mut ws = PlantWorkspace::new(&p);
        let (s, obs) = plant::observe(&p, &PlantState::at_rest(scen.q0, scen.seed), &mut ws, [0.0; 6], false);
        Ok(SimPlant { p, s, ws, obs, data })
    }
}

/// The plant the driver's parameters describe.
pub fn make_plant(p: &naic_ros::ParamView) -> Result<SimPlant, String> {
    SimPlant::new(p.str("urdf"), p.str("scenario"), p.str("friction_file"), p.f64("friction_smoothing"), 1.0 / p.f64("rate"))
}

impl Plant for SimPlant {
    fn step(&mut self, tau: &[f64; 6], _dt: f64) {
        let (s, obs) = plant::step(&self.p, &self.s, tau, &mut self.ws);
        self.s = s;
        self.obs = obs;
    }
    fn hold_torque(&mut self, damping: f64) -> [f64; 6] {
        let g = *dynamics::gravity_torques(&self.p.model, &mut self.data, &Vector6::from(self.s.q));
        std::array::from_fn(|i| g[i] - damping * self.s.dq[i])
    }
    fn joints(&self) -> ([f64; 6], [f64; 6], [f64; 6]) {
        (self.obs.meas.q, self.obs.meas.dq, self.obs.truth.tau_applied)
    }
    fn wrench(&self) -> [f64; 6] {
        self.obs.meas.wrench
    }
    fn time(&self) -> f64 {
        self.s.t
    }
}
