//! The driver's simulator: `naic_sim`'s arm + ATI mini45 (`SimArm`) in a scenario: the
//! paper's JK5 in a paper scenario, or a robot file's arm in the scenario placed relative to
//! its start joints (as `naic sim --robot` runs it).

use std::any::Any;

use naic_core::{
    friction::{FrictionParams, Smoothing},
    model::{DataN, Model},
    pipeline::hold,
    robot_file::Robot,
    JointVec, N_JOINTS,
};
use naic_sim::{plants::PlantChoice, scenario, sensor::tool_from_urdf};
use naic_ros::params::ParamError;

use crate::plant::Plant;

/// Which simulator the driver runs (the read-only `plant` parameter).
pub const PLANT_NAME: &str = "naic_sim";

const FRICTION_FIX: &str = "set -p friction_file:=PATH, e.g. params/friction_jk5.yaml";

/// The plant the parameters name, for an arm of `N` joints: the robot file's arm (`robot`,
/// not the paper's JK5) in the scenario placed relative to its `start_q`, or else the
/// JK5's plant ([`make_jk5_plant`], unchanged).
pub fn make_plant<const N: usize>(p: &naic_ros::ParamView, robot: Option<&Robot>) -> Result<SimPlant<N>, ParamError> {
    match robot.filter(|r| !r.is_paper_jk5()) {
        Some(r) => make_robot_plant::<N>(p, r),
        None => {
            let six: Box<dyn Any> = Box::new(make_jk5_plant(p)?);
            // The JK5's plant has six joints; the shell was dispatched on the same count.
            six.downcast::<SimPlant<N>>().map(|b| *b).map_err(|_| {
                ParamError::file("urdf", p.str("urdf"), format!("the JK5's plant has {N_JOINTS} joints, not {N}"), "give the arm as -p robot:=FILE")
            })
        }
    }
}

/// A robot file's arm (any joint count): the scenario `scenario` placed relative to its
/// `start_q` (`naic_sim::scenario::preset_relative`), its friction (`friction_file`, by
/// default the robot file's; none: no joint friction), its tool (a point mass at the tool's
/// centre of mass when the URDF has no `ft_sensor` link) and F/T sensor model, on the own
/// plant (MuJoCo steps the JK5's MJCF only).
fn make_robot_plant<const N: usize>(p: &naic_ros::ParamView, r: &Robot) -> Result<SimPlant<N>, ParamError> {
    let (name, friction_file) = (p.str("scenario"), p.str("friction_file"));
    let file = r.file.display().to_string();
    let bad = |problem: String, fix: &'static str| ParamError::file("robot", &file, problem, fix);
    let q = r.start_q.as_ref().filter(|q| q.len() == N).ok_or_else(|| {
        bad("the simulated arm starts at the robot file's `start_q`, and it has none".into(), "add start_q (joints [rad], the tool pointing along a base axis) to the robot file")
    })?;
    let q0: JointVec<N> = std::array::from_fn(|i| q[i]);
    let mut scen = scenario::preset_relative::<N>(name, &r.model, q0)
        .map_err(|e| bad(format!("scenario '{name}': {e}"), "choose another -p scenario:=, or another start_q"))?;
    scen.task.dt = 1.0 / p.f64("rate");
    if p.str("plant") != "naic_sim" && p.str("plant") != "own" {
        return Err(ParamError::file("plant", p.str("plant"), "MuJoCo steps the JK5's MJCF only", "drop -p plant:= for a robot file (naic's own plant runs any arm)"));
    }
    let friction = if friction_file.is_empty() {
        None
    } else {
        let bad_friction = |problem: String| ParamError::file("friction_file", friction_file, problem, FRICTION_FIX);
        let f = FrictionParams::from_yaml_file(friction_file)
            .and_then(|f| f.to_model())
            .and_then(|m| m.with_smoothing(Smoothing::Tanh { v_s: p.f64("friction_smoothing") }))
            .map_err(|e| bad_friction(format!("friction_file '{friction_file}': {e}")))?;
        if f.n_joints() != N {
            return Err(bad_friction(format!("friction_file '{friction_file}' has {} joints; the arm has {N}", f.n_joints())));
        }
        Some(f)
    };
    let mut params = scenario::plant_for(&scen, r.model.clone(), friction, r.tool_tuple())
        .map_err(|e| bad(format!("scenario '{name}': {e}"), "check the robot file's frames and start_q"))?;
    // The tool's inertia: the URDF's ft_sensor link's, or none (a point mass) for a new frame.
    let inertia = match naic_sim::sensor::tool_inertia_from_urdf(&r.urdf) {
        Err(naic_sim::sensor::ToolError::NoSensorLink { .. }) => nalgebra::Matrix3::zeros(),
        i => i.map_err(|e| bad(e.to_string(), "check the URDF's ft_sensor link"))?,
    };
    params.ft = params.ft.with_tool_inertia(inertia);
    scenario::apply_sensor_spec(&mut params, &r.sensor);
    let data = DataN::<N>::try_new(&params.model).map_err(|e| bad(e.to_string(), "check the URDF"))?;
    let arm = PlantChoice::Own.build_n::<N>(&params, &scen.task.q0, scen.seed).map_err(|e| bad(e.to_string(), "check the robot file"))?;
    Ok(SimPlant { arm, model: params.model, data, dt: scen.task.dt })
}

/// The plant of scenario `scenario` (naic_sim presets) on `urdf`, with the friction of
/// `friction_file` (tanh-smoothed with `v_s`; '' for none) acting on the joints, on either
/// plant, at period `1/rate`.
pub fn make_jk5_plant(p: &naic_ros::ParamView) -> Result<SimPlant, ParamError> {
    let (urdf, name, friction_file) = (p.str("urdf"), p.str("scenario"), p.str("friction_file"));
    const URDF_FIX: &str = "set -p urdf:=PATH";
    let bad_urdf = |problem: String| ParamError::file("urdf", urdf, problem, URDF_FIX);
    let bad_friction = |problem: String| ParamError::file("friction_file", friction_file, problem, FRICTION_FIX);
    let model = Model::from_urdf_file(urdf).map_err(|e| bad_urdf(format!("robot model '{urdf}': {e}")))?;
    let mut scen = scenario::preset(name, &model).map_err(|e| bad_urdf(format!("scenario '{name}' on robot model '{urdf}': {e}")))?;
    scen.task.dt = 1.0 / p.f64("rate");
    let choice = match p.str("plant") {
        "naic_sim" | "own" => PlantChoice::Own,
        "mujoco" => PlantChoice::Mujoco { mjcf: p.str("mjcf").into() },
        other => {
            return Err(ParamError::file("plant", other, format!("unknown plant '{other}'"), "set -p plant:=naic_sim or -p plant:=mujoco"));
        }
    };
    // '' for frictionless joints; on plant:=mujoco MuJoCo computes it (naic_sim::mujoco_plant).
    let friction = if friction_file.is_empty() {
        None
    } else {
        let f = FrictionParams::from_yaml_file(friction_file)
            .and_then(|f| f.to_model())
            .and_then(|m| m.with_smoothing(Smoothing::Tanh { v_s: p.f64("friction_smoothing") }))
            .map_err(|e| bad_friction(format!("friction_file '{friction_file}': {e}")))?;
        if f.n_joints() != N_JOINTS {
            return Err(bad_friction(format!("friction_file '{friction_file}' has {} joints; the JK5 needs {N_JOINTS}", f.n_joints())));
        }
        Some(f)
    };
    let (mass, com) = tool_from_urdf(std::path::Path::new(urdf)).map_err(|e| bad_urdf(e.to_string()))?;
    // The true tool may differ from the URDF's (tool_mass_error, tool_com_offset).
    let off = p.f64s("tool_com_offset");
    let [ox, oy, oz] = off else {
        return Err(ParamError::from(format!("tool_com_offset: give 3 numbers [x, y, z] in m (sensor frame), got {}", off.len())));
    };
    let mut com = com;
    (com.x, com.y, com.z) = (com.x + ox, com.y + oy, com.z + oz);
    let tool = (mass * p.f64("tool_mass_error"), com);
    let mut params = scenario::plant_for(&scen, model, friction, tool)
        .map_err(|e| bad_urdf(format!("robot model '{urdf}' in scenario '{name}': {e}")))?;
    // The tool's inertial wrench on the sensor (issue 36 item 4), as `naic sim`.
    let inertia = naic_sim::sensor::tool_inertia_from_urdf(std::path::Path::new(urdf)).map_err(|e| bad_urdf(e.to_string()))?;
    params.ft = params.ft.with_tool_inertia(inertia);
    let data = DataN::<N_JOINTS>::try_new(&params.model).map_err(|e| bad_urdf(format!("robot model '{urdf}': {e}")))?;
    let dt = scen.task.dt;
    let arm = choice
        .build(&params, &scen.task.q0, scen.seed)
        .map_err(|e| ParamError::file("plant", p.str("plant"), e.to_string(), "set -p plant:=naic_sim, or -p mjcf:=FILE with a MuJoCo build"))?;
    Ok(SimPlant { arm, model: params.model, data, dt })
}

/// The simulated arm plus the workspace of the driver's hold.
pub struct SimPlant<const N: usize = N_JOINTS> {
    /// The plant of the `plant` parameter (`naic_sim::plants`).
    arm: Box<dyn naic_sim::plants::Plant<N> + Send>,
    /// The URDF model the hold law uses.
    model: Model,
    data: DataN<N>,
    /// Control period [s] (1/rate): the hold's damping is capped for stability at it.
    dt: f64,
}

impl<const N: usize> Plant<N> for SimPlant<N> {
    fn step(&mut self, tau: &JointVec<N>, _dt: f64) {
        self.arm.step(tau)
    }
    /// The core's hold law (`naic_core::pipeline::hold`) at the measured joint state, as a
    /// real driver would compute it from its encoders.
    fn hold_torque(&mut self, damping: f64) -> JointVec<N> {
        let (q, dq, _) = self.joints();
        hold::torque(&self.model, &mut self.data, &q, &dq, &[damping; N], self.dt)
    }
    /// Measured positions and velocities, and the applied torques.
    fn joints(&self) -> (JointVec<N>, JointVec<N>, JointVec<N>) {
        let o = self.arm.observation();
        (o.meas.q, o.meas.dq, o.truth.tau_applied)
    }
    fn wrench(&self) -> [f64; 6] {
        self.arm.observation().meas.wrench
    }
    fn time(&self) -> f64 {
        self.arm.observation().meas.t
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{UnitQuaternion, Vector3, Vector6};
    use naic_core::pipeline::{
        control::{force_law::{Mode, DEFAULT_GAMMA}, Phase},
        controller::{self, Controller, ControllerParams, Reference},
        sense::RawMeasurements,
    };
    use naic_ros::RosArgs;

    use super::*;
    use crate::setup::Setup;
    use naic_core::model::Data6;

    /// The driver's plant on the repository's JK5 files (scenario `flat`, 1 kHz).
    fn plant() -> SimPlant {
        let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");
        let args = [
            "--ros-args".to_string(),
            "-p".into(),
            format!("urdf:={root}/urdf/jk5.urdf"),
            "-p".into(),
            format!("friction_file:={root}/params/friction_jk5.yaml"),
        ];
        Setup::from_args(&RosArgs::parse(args).unwrap()).unwrap().plant
    }

    /// One hold law: the driver's hold (no command) and the controller's fault hold give
    /// the same torque at the same measured joint state.
    #[test]
    fn the_drivers_hold_is_the_controllers_fault_hold_at_the_measured_state() {
        let mut plant = plant();
        // Let the arm fall for 30 ms, so the damping term is not zero.
        for _ in 0..30 {
            plant.step(&[0.0; 6], 1e-3);
        }
        let (q, dq, _) = plant.joints();
        assert!(dq.iter().any(|v| v.abs() > 1e-2), "the arm did not move: the damping would be untested ({dq:?})");
        let driver = plant.hold_torque(5.0);

        let model = plant.model.clone();
        let mut cp = ControllerParams::paper_defaults(&model, Mode::Naic, DEFAULT_GAMMA);
        cp.hold_damping = [5.0; 6];
        assert_eq!(cp.control.force_law.lambda, plant.dt, "same control period");
        let ctl = Controller::new(model.clone(), cp).unwrap();
        let mut ws = ctl.workspace();
        let r = Reference { p_d: Vector3::new(-0.4, -0.11, 0.05), r_d: UnitQuaternion::identity(), v_d: Vector6::zeros(), a_d: Vector6::zeros(), f_d: 10.0 };
        let mut bad = [0.0; 6];
        bad[2] = f64::NAN;
        let meas = RawMeasurements { t: 0.0, q, dq, joints_stamp: 0.0, wrench: bad, wrench_stamp: 0.0 };
        let (_, out) = controller::step(&ctl, &ctl.initial_state(), &meas, &r, &mut ws);
        assert_eq!(out.status.phase, Phase::Hold, "a NaN wrench must make the controller hold");
        for i in 0..6 {
            assert!((out.tau[i] - driver[i]).abs() < 1e-12, "joint {i}: driver {} vs controller {}", driver[i], out.tau[i]);
        }
        // Not gravity alone: the damping of the moving joints is in both.
        let gravity = hold::torque(&model, &mut Data6::try_new(&model).unwrap(), &q, &[0.0; 6], &[5.0; 6], 1e-3);
        assert!((0..6).any(|i| (driver[i] - gravity[i]).abs() > 1e-3), "{driver:?} vs gravity {gravity:?}");
    }
}
