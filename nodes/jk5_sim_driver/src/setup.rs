//! Building the driver from its arguments, before any DDS participant exists: the robot
//! model (effort limits, joint names; a robot file's with `-p robot:=FILE`), then the whole
//! plant (model, scenario, friction file).

use naic_core::{robot_file::Robot, JointVec};
use naic_ros::{ParamSpec, ParamTable, RosArgs, RosError};

use crate::{
    config,
    sim_plant::{make_plant, SimPlant},
};

pub const NODE: &str = "jk5_sim_driver";

/// What the node is built from, read before any DDS participant exists (an arm of `N`
/// joints).
pub struct Setup<const N: usize = { naic_core::N_JOINTS }> {
    /// The URDF's `<limit effort>`: the highest `effort_limit` a parameter may set.
    pub urdf_effort: JointVec<N>,
    /// The arm's joint names: `/joint_states` carries them; commands are in their order.
    pub joints: [String; N],
    pub plant: SimPlant<N>,
    /// What the robot file changes in the parameters' defaults.
    pub defaults: naic_ros::robot::Defaults,
}

/// The arm of the node's arguments: the robot file (`-p robot:=FILE`, if given) and its
/// joint count (the JK5's six without one); the shell runs [`Setup::for_arm`] with it.
pub fn arm(args: &RosArgs) -> Result<(Option<Robot>, usize), RosError> {
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
    /// Files first: the robot model (effort limits), then the whole plant (model,
    /// scenario, friction file) from the start-up parameters. `robot`: the robot file
    /// ([`arm`]); without one, the JK5 as always.
    pub fn for_arm(args: &RosArgs, robot: Option<Robot>) -> Result<Setup<N>, RosError> {
        let joints = naic_ros::robot::joint_names::<N>(robot.as_ref(), NODE)?;
        let (urdf_effort, defaults) = match &robot {
            None => {
                let urdf = args.peek_string(NODE, "urdf", "urdf/jk5.urdf")?;
                let model = naic_core::model::Model::from_urdf_file(&urdf);
                naic_ros::params::urdf_effort_limits(&urdf)?;
                let model = model.map_err(|e| RosError::param(format!("robot model '{urdf}': {e}")))?;
                let effort = naic_ros::params::model_effort_limits::<N>(&model, "urdf", &urdf)?;
                (effort, naic_ros::robot::Defaults::new(None, "urdf/jk5.urdf", "params/friction_jk5.yaml"))
            }
            Some(r) => {
                let urdf = r.urdf.display().to_string();
                if args.peek_string(NODE, "urdf", &urdf)? != urdf {
                    return Err(RosError::param(format!("-p urdf:=... and -p robot:={}: give the URDF in the robot file, or drop robot", r.file.display())));
                }
                let effort = naic_ros::params::model_effort_limits::<N>(&r.model, "robot", &r.file.display().to_string())?;
                let friction = r.friction.as_ref().map(|f| f.0.display().to_string()).unwrap_or_default();
                (effort, naic_ros::robot::Defaults::new(Some(r), &urdf, &friction))
            }
        };
        let specs = defaults.apply(config::specs(&urdf_effort, &joints));
        let plant = ParamTable::new(specs, Some(config::check(urdf_effort, joints.clone())), &args.overrides(NODE)?)?
            .with(|p| make_plant::<N>(p, robot.as_ref()))?;
        Ok(Setup { urdf_effort, joints, plant, defaults })
    }

    pub fn specs(&self) -> Vec<ParamSpec> {
        self.defaults.apply(config::specs(&self.urdf_effort, &self.joints))
    }

    pub fn check(&self) -> naic_ros::params::SetCheck {
        config::check(self.urdf_effort, self.joints.clone())
    }
}
