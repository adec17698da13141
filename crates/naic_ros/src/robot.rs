//! `-p robot:=FILE` for the nodes: the robot file (`naic_core::robot_file`, docs/robots.md)
//! read before any DDS participant exists, the joint names it gives, and the parameter
//! defaults it changes (`urdf`, `friction_file`, `base_frame`).

use naic_core::robot_file::Robot;

use crate::{ParamSpec, ParameterValue, RosArgs, RosError};

/// The robot file of `-p robot:=FILE` (`None`: not given; the node runs the JK5 as always).
pub fn from_args(args: &RosArgs, node: &str) -> Result<Option<Robot>, RosError> {
    let path = args.peek_string(node, "robot", "")?;
    if path.is_empty() {
        return Ok(None);
    }
    Robot::load(&path).map(Some).map_err(|e| RosError::param(format!("{e} (-p robot:=FILE names a robot file, docs/robots.md)")))
}

/// The arm's joint names in command order: the robot file's, or the JK5's `joint1..joint6`.
/// A robot file with another joint count than this node's shell runs is an error naming both.
pub fn joint_names<const N: usize>(robot: Option<&Robot>, node: &str) -> Result<[String; N], RosError> {
    let Some(r) = robot else {
        return Ok(std::array::from_fn(|i| crate::msgs::JOINT_NAMES.get(i).map_or_else(|| format!("joint{}", i + 1), |s| s.to_string())));
    };
    if r.joints.len() != N {
        return Err(RosError::param(format!(
            "robot file {}: {} joints ({}); the {node} node runs {N}-joint arms so far (`naic sim --robot` runs 3 to 7 in process)",
            r.file.display(),
            r.joints.len(),
            r.joints.join(", ")
        )));
    }
    Ok(std::array::from_fn(|i| r.joints[i].clone()))
}

/// What a robot file changes in a node's parameter defaults.
#[derive(Clone, Debug, Default)]
pub struct Defaults {
    robot: String,
    urdf: String,
    friction_file: String,
    base_frame: Option<String>,
}

impl Defaults {
    /// `urdf` and `friction_file`: the defaults the node uses (the robot file's when given).
    pub fn new(robot: Option<&Robot>, urdf: &str, friction_file: &str) -> Self {
        Defaults {
            robot: robot.map(|r| r.file.display().to_string()).unwrap_or_default(),
            urdf: urdf.to_string(),
            friction_file: friction_file.to_string(),
            base_frame: robot.map(|r| r.base_frame.clone()),
        }
    }

    /// The node's specs with these defaults, and the read-only `robot` parameter.
    pub fn apply(&self, mut specs: Vec<ParamSpec>) -> Vec<ParamSpec> {
        for s in &mut specs {
            match s.name.as_str() {
                "urdf" => s.default = ParameterValue::String(self.urdf.clone()),
                "friction_file" => s.default = ParameterValue::String(self.friction_file.clone()),
                "base_frame" => {
                    if let Some(b) = &self.base_frame {
                        s.default = ParameterValue::String(b.clone());
                    }
                }
                _ => {}
            }
        }
        specs.push(
            ParamSpec::string("robot", &self.robot, "Robot file (docs/robots.md): URDF, joint names, friction file, frames, start joints ('': the JK5 of urdf/jk5.urdf)")
                .read_only(),
        );
        specs
    }
}
