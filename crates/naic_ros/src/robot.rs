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

/// The joint count a node's shell is compiled for (`naic_core::with_joints!`): the robot
/// file's joints, else the JK5's six. A URDF of another joint count without a robot file
/// is refused here, naming the fix (a robot file names its joints, frames and start).
pub fn joint_count(args: &RosArgs, robot: Option<&Robot>, node: &str, default_urdf: &str) -> Result<usize, RosError> {
    if let Some(r) = robot {
        return Ok(r.joints.len());
    }
    let urdf = args.peek_string(node, "urdf", default_urdf)?;
    // A URDF that does not load is the node's set-up's to report (it names the file).
    let Ok(model) = naic_core::model::Model::from_urdf_file(&urdf) else { return Ok(naic_core::N_JOINTS) };
    if model.nv() != naic_core::N_JOINTS {
        return Err(RosError::param(format!(
            "-p urdf:={urdf}: {} joints; without a robot file the {node} node runs the JK5's {} joints: give the arm as -p robot:=FILE (docs/robots.md: URDF, joints, frames, start_q)",
            model.nv(),
            naic_core::N_JOINTS
        )));
    }
    Ok(naic_core::N_JOINTS)
}

/// The arm's joint names in command order: the robot file's, or the JK5's `joint1..joint6`.
/// A robot file with another joint count than the shell was dispatched for
/// ([`joint_count`]) is an error naming both.
pub fn joint_names<const N: usize>(robot: Option<&Robot>, node: &str) -> Result<[String; N], RosError> {
    let Some(r) = robot else {
        return Ok(std::array::from_fn(|i| crate::msgs::JOINT_NAMES.get(i).map_or_else(|| format!("joint{}", i + 1), |s| s.to_string())));
    };
    if r.joints.len() != N {
        return Err(RosError::param(format!(
            "robot file {}: {} joints ({}); this {node} shell was started for {N} joints",
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
