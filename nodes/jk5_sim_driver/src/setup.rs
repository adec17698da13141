//! Building the driver from its arguments, before any DDS participant exists: the robot
//! model (effort limits), then the whole plant (model, scenario, friction file).

use naic_core::JointVec;
use naic_ros::{ParamSpec, ParamTable, RosArgs, RosError};

use crate::{
    config,
    sim_plant::{make_plant, SimPlant},
};

pub const NODE: &str = "jk5_sim_driver";

/// What the node is built from, read before any DDS participant exists.
pub struct Setup {
    /// The URDF's `<limit effort>`: the highest `effort_limit` a parameter may set.
    pub urdf_effort: JointVec,
    pub plant: SimPlant,
}

impl Setup {
    /// Files first: the robot model (effort limits), then the whole plant (model,
    /// scenario, friction file) from the start-up parameters.
    pub fn from_args(args: &RosArgs) -> Result<Setup, RosError> {
        let urdf = args.peek_string(NODE, "urdf", "urdf/jk5.urdf")?;
        let urdf_effort = naic_ros::params::urdf_effort_limits(&urdf)?;
        let plant = ParamTable::new(config::specs(&urdf_effort), Some(config::check(urdf_effort)), &args.overrides(NODE)?)?
            .with(make_plant)?;
        Ok(Setup { urdf_effort, plant })
    }

    pub fn specs(&self) -> Vec<ParamSpec> {
        config::specs(&self.urdf_effort)
    }

    pub fn check(&self) -> naic_ros::params::SetCheck {
        config::check(self.urdf_effort)
    }
}
