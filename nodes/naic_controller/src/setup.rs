//! Building the node from its arguments: every file and start-up value is read and checked
//! here, before any DDS participant exists (a bad one exits with code 2, naming it).

use naic_core::{
    friction::FrictionParams,
    model::Model,
    pipeline::feedforward::FastVelocity,
    pipeline::{control::force_law::{self, Mode}, controller::{Controller, ControllerParams}},
};
use naic_ros::{ParamSpec, ParamTable, RosArgs, RosError};

use crate::{config, core, reference::ScenarioReference};

pub const NODE: &str = "naic_controller";

/// The node's core parameters and what its ROS parameters are declared from, for an arm
/// of `N` joints.
pub struct Setup<const N: usize = { naic_core::N_JOINTS }> {
    pub params: core::Params<N>,
    /// The core's paper settings on the loaded model: the parameters' defaults.
    pub base: ControllerParams<N>,
    /// What the robot file changes in the parameters' defaults.
    pub defaults: naic_ros::robot::Defaults,
}

/// The arm of the node's arguments: the robot file (`-p robot:=FILE`, if given) and its
/// joint count (the JK5's six without one; [`naic_ros::robot::joint_count`]). The shell
/// runs [`Setup::for_arm`] with that count (`naic_core::with_joints!`).
pub fn arm(args: &RosArgs) -> Result<(Option<naic_core::robot_file::Robot>, usize), RosError> {
    let robot = naic_ros::robot::from_args(args, NODE)?;
    let n = naic_ros::robot::joint_count(args, robot.as_ref(), NODE, "urdf/jk5.urdf")?;
    Ok((robot, n))
}

impl Setup {
    /// The JK5 (or the 6-joint arm of a robot file): [`Setup::for_arm`] with six joints.
    pub fn from_args(args: &RosArgs) -> Result<Setup, RosError> {
        let (robot, _) = arm(args)?;
        Setup::for_arm(args, robot)
    }
}

impl<const N: usize> Setup<N> {
    /// Read and check everything that reads a file or can reject the model: the start-up
    /// parameters, the model (N joints, 'tip' and 'ft_sensor' frames) and the scenario.
    /// `robot`: the robot file ([`arm`]); a robot file gives the URDF, the joint names, the
    /// friction file and the frames; without one, the JK5 as always.
    pub fn for_arm(args: &RosArgs, robot: Option<naic_core::robot_file::Robot>) -> Result<Setup<N>, RosError> {
        let joints = naic_ros::robot::joint_names::<N>(robot.as_ref(), NODE)?;
        let (urdf_default, friction_default) = match &robot {
            Some(r) => (r.urdf.display().to_string(), r.friction.as_ref().map(|f| f.0.display().to_string()).unwrap_or_default()),
            None => ("urdf/jk5.urdf".to_string(), config::FRICTION_FILE.to_string()),
        };
        let urdf = args.peek_string(NODE, "urdf", &urdf_default)?;
        let model = match &robot {
            Some(r) if urdf == urdf_default => r.model.clone(),
            Some(r) => return Err(RosError::param(format!("-p urdf:={urdf} and -p robot:={}: give the URDF in the robot file, or drop robot", r.file.display()))),
            None => Model::from_urdf_file(&urdf)
                .map_err(|e| RosError::param(format!("cannot load the robot model '{urdf}': {e} (set -p urdf:=PATH)")))?,
        };
        // Defaults: the core's paper settings on this model (learning rate: not in the paper),
        // with the law docs/controller.md recommends ('scheduled'); the paper's laws are a
        // `mode` away.
        let mut base = ControllerParams::<N>::paper_defaults(&model, Mode::Scheduled, force_law::DEFAULT_GAMMA);
        // Another arm's tool (the JK5's is the paper defaults' already).
        if let Some(r) = robot.as_ref().filter(|r| !r.is_paper_jk5()) {
            base.tool.mass = r.tool.mass;
            base.tool.com = r.tool.com;
            if let Some(tip) = r.tip_in_sensor() {
                base.tool.tip = tip;
            }
        }
        // Mode scheduled: the unfiltered velocity in contact in the friction model's Stribeck
        // drops (docs/controller.md), as `naic sim` sets it.
        let friction_file = args.peek_string(NODE, "friction_file", &friction_default)?;
        if !friction_file.is_empty() {
            let model = FrictionParams::load_feedforward_model(&friction_file).map_err(|e| {
                RosError::param(format!("cannot load the friction model '{friction_file}': {e} (set -p friction_file:=PATH, or '' for none)"))
            })?;
            base.control.force_law.scheduled.friction_fast = Some(FastVelocity::for_model(&model));
        }
        let defaults = naic_ros::robot::Defaults::new(robot.as_ref(), &urdf_default, &friction_default);
        let table = ParamTable::new(defaults.apply(config::specs(&base)), Some(config::check(base)), &args.overrides(NODE)?)?;
        let bad_model = |e: naic_core::pipeline::ConfigError| RosError::param(format!("robot model '{urdf}': {e} (set -p urdf:=PATH)"));
        let cp = table.with(|p| config::controller_params(p, &base))?;
        if let Some(line) = naic_core::pipeline::control::law::approach_report(&cp.control, table.with(|p| p.f64("desired_force"))) {
            log::info!("{line}");
        }
        // The model first (its message names the URDF file), then the scenario.
        let ctl = Controller::new(model.clone(), cp).map_err(bad_model)?;
        let scenario = table.with(|p| p.str("scenario").to_string());
        let reference = match &robot {
            Some(r) if !r.is_paper_jk5() => ScenarioReference::for_robot::<N>(&scenario, r),
            _ => ScenarioReference::new(&scenario, &model),
        }
        .map_err(|e| RosError::param(format!("scenario '{scenario}': {e} (-p scenario:=none for a real arm)")))?;
        let rp = table.with(config::reference_params);
        let params = core::Params::new(ctl, table.with(config::settings), reference, rp, joints).map_err(bad_model)?;
        Ok(Setup { params, base, defaults })
    }

    pub fn specs(&self) -> Vec<ParamSpec> {
        self.defaults.apply(config::specs(&self.base))
    }

    pub fn check(&self) -> naic_ros::params::SetCheck {
        config::check(self.base)
    }
}
