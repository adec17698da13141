//! Building the node from its arguments, before any DDS participant exists: the robot
//! model (effort limits, the velocity filter) and the check of parameter values.

use naic_core::{model::Model, pipeline::sense::SenseParams, JointVec};
use naic_ros::{
    params::{effort_limit_within, SetCheck},
    ParamSpec, ParamView, RosArgs, RosError,
};

use crate::config;

pub const NODE: &str = "friction_compensation";

/// What the node is built from, read before any DDS participant exists (an arm of `N`
/// joints).
pub struct Setup<const N: usize = { naic_core::N_JOINTS }> {
    /// The URDF's `<limit effort>` (capped): the highest saturation a parameter may set.
    pub effort_limit: JointVec<N>,
    /// The velocity filter: the controller's sense stage (joint limits of the model).
    pub sense: SenseParams<N>,
    /// The arm's joint names in command order (the robot file's, or the JK5's).
    pub joints: [String; N],
    /// What the robot file changes in the parameters' defaults.
    pub defaults: naic_ros::robot::Defaults,
}

/// The arm of the node's arguments: the robot file (`-p robot:=FILE`, if given) and its
/// joint count (the JK5's six without one); the shell runs [`Setup::for_arm`] with it.
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
    /// `file`: the robot file ([`arm`]): its URDF, joint names and friction file (none when
    /// it gives none); without one, the JK5 as always.
    pub fn for_arm(args: &RosArgs, file: Option<naic_core::robot_file::Robot>) -> Result<Setup<N>, RosError> {
        let joints = naic_ros::robot::joint_names::<N>(file.as_ref(), NODE)?;
        let (effort_limit, robot, defaults) = match &file {
            None => {
                let urdf = args.peek_string(NODE, "urdf", "urdf/jk5.urdf")?;
                naic_ros::params::urdf_effort_limits(&urdf)?;
                let robot = Model::from_urdf_file(&urdf).map_err(|e| RosError::param(format!("robot model '{urdf}': {e}")))?;
                let effort_limit = naic_ros::params::model_effort_limits::<N>(&robot, "urdf", &urdf)?;
                (effort_limit, robot, naic_ros::robot::Defaults::new(None, "urdf/jk5.urdf", "params/friction_jk5.yaml"))
            }
            Some(r) => {
                let urdf = r.urdf.display().to_string();
                if args.peek_string(NODE, "urdf", &urdf)? != urdf {
                    return Err(RosError::param(format!("-p urdf:=... and -p robot:={}: give the URDF in the robot file, or drop robot", r.file.display())));
                }
                let effort_limit = naic_ros::params::model_effort_limits::<N>(&r.model, "robot", &r.file.display().to_string())?;
                let friction = r.friction.as_ref().map(|f| f.0.display().to_string()).unwrap_or_default();
                (effort_limit, r.model.clone(), naic_ros::robot::Defaults::new(Some(r), &urdf, &friction))
            }
        };
        let sense = SenseParams { wrench_max: [f64::INFINITY; 6], joint_timeout: 1.0, wrench_timeout: 1.0, ..SenseParams::<N>::for_model(&robot) };
        Ok(Setup { effort_limit, sense, joints, defaults })
    }

    pub fn specs(&self) -> Vec<ParamSpec> {
        self.defaults.apply(config::specs(&self.effort_limit))
    }

    /// A friction file that does not load, or a saturation above the URDF's, is rejected
    /// like any bad value.
    pub fn check(&self) -> SetCheck {
        let effort_limit = self.effort_limit;
        Box::new(move |p: &ParamView| {
            effort_limit_within(p, &effort_limit)?;
            config::load_model::<N>(p).map(|_| ()).map_err(Into::into)
        })
    }
}
