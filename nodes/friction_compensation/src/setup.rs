//! Building the node from its arguments, before any DDS participant exists: the robot
//! model (effort limits, the velocity filter) and the check of parameter values.

use naic_core::{model::Model, pipeline::sense::SenseParams, JointVec};
use naic_ros::{
    params::{effort_limit_within, SetCheck},
    ParamSpec, ParamView, RosArgs, RosError,
};

use crate::config;

pub const NODE: &str = "friction_compensation";

/// What the node is built from, read before any DDS participant exists.
pub struct Setup {
    /// The URDF's `<limit effort>` (capped): the highest saturation a parameter may set.
    pub effort_limit: JointVec,
    /// The velocity filter: the controller's sense stage (joint limits of the model).
    pub sense: SenseParams,
    /// The arm's joint names in command order (the robot file's, or the JK5's).
    pub joints: [String; naic_core::N_JOINTS],
    /// What the robot file changes in the parameters' defaults.
    pub defaults: naic_ros::robot::Defaults,
}

impl Setup {
    pub fn from_args(args: &RosArgs) -> Result<Setup, RosError> {
        // A robot file (`-p robot:=FILE`, docs/robots.md): its URDF, joint names and friction
        // file (none when it gives none); without one, the JK5 as always.
        let file = naic_ros::robot::from_args(args, NODE)?;
        let joints = naic_ros::robot::joint_names(file.as_ref(), NODE)?;
        let (effort_limit, robot, defaults) = match &file {
            None => {
                let urdf = args.peek_string(NODE, "urdf", "urdf/jk5.urdf")?;
                let effort_limit = naic_ros::params::urdf_effort_limits(&urdf)?;
                let robot = Model::from_urdf_file(&urdf).map_err(|e| RosError::param(format!("robot model '{urdf}': {e}")))?;
                (effort_limit, robot, naic_ros::robot::Defaults::new(None, "urdf/jk5.urdf", "params/friction_jk5.yaml"))
            }
            Some(r) => {
                let urdf = r.urdf.display().to_string();
                if args.peek_string(NODE, "urdf", &urdf)? != urdf {
                    return Err(RosError::param(format!("-p urdf:=... and -p robot:={}: give the URDF in the robot file, or drop robot", r.file.display())));
                }
                let l = r.model.effort_limits();
                let effort_limit: JointVec = std::array::from_fn(|i| l[i].min(naic_ros::params::EFFORT_CAP));
                let friction = r.friction.as_ref().map(|f| f.0.display().to_string()).unwrap_or_default();
                (effort_limit, r.model.clone(), naic_ros::robot::Defaults::new(Some(r), &urdf, &friction))
            }
        };
        let sense = SenseParams { wrench_max: [f64::INFINITY; 6], joint_timeout: 1.0, wrench_timeout: 1.0, ..SenseParams::for_model(&robot) };
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
            config::load_model(p).map(|_| ()).map_err(Into::into)
        })
    }
}
