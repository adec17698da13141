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
}

impl Setup {
    pub fn from_args(args: &RosArgs) -> Result<Setup, RosError> {
        let urdf = args.peek_string(NODE, "urdf", "urdf/jk5.urdf")?;
        let effort_limit = naic_ros::params::urdf_effort_limits(&urdf)?;
        let robot = Model::from_urdf_file(&urdf).map_err(|e| RosError::param(format!("robot model '{urdf}': {e}")))?;
        let sense = SenseParams { wrench_max: [f64::INFINITY; 6], joint_timeout: 1.0, wrench_timeout: 1.0, ..SenseParams::for_model(&robot) };
        Ok(Setup { effort_limit, sense })
    }

    pub fn specs(&self) -> Vec<ParamSpec> {
        config::specs(&self.effort_limit)
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
