//! What arrives on the reference topics, and the checks a sample must pass
//! before it becomes the target. A rejected sample is a value ([`Rejection`]);
//! the node shell logs it (rate-limited, naming the frame it got).

use nalgebra::{Quaternion, UnitQuaternion, Vector3};

/// A `/naic/target_pose` sample (`geometry_msgs/PoseStamped`), borrowed from the message.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TargetPose<'a> {
    /// `header.frame_id`: must be the base frame.
    pub frame_id: &'a str,
    /// `header.stamp` [s] (the publisher's clock; only differences between samples are used).
    pub stamp: f64,
    /// `pose.position` [m], base frame.
    pub position: [f64; 3],
    /// `pose.orientation` as (x, y, z, w), the message's order.
    pub orientation: [f64; 4],
}

/// A `/naic/desired_wrench` sample (`geometry_msgs/WrenchStamped`): the wrench the tool
/// should apply to the environment, base frame. Only the force along the force axis is used.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DesiredWrench<'a> {
    pub frame_id: &'a str,
    pub stamp: f64,
    /// `wrench.force` [N].
    pub force: [f64; 3],
    /// `wrench.torque` [N·m] (checked, not used).
    pub torque: [f64; 3],
}

/// Which field of a sample a rejection concerns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Field {
    Stamp,
    Position,
    Orientation,
    Force,
    Torque,
}

impl Field {
    pub fn as_str(self) -> &'static str {
        match self {
            Field::Stamp => "header.stamp",
            Field::Position => "pose.position",
            Field::Orientation => "pose.orientation",
            Field::Force => "wrench.force",
            Field::Torque => "wrench.torque",
        }
    }
}

/// Why a sample was not taken as the target. `Copy`: the 1 kHz path never allocates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rejection {
    /// `header.frame_id` is not the base frame (the node's core expresses samples given in
    /// other frames of the robot model in the base frame before this stage: what reaches
    /// it in another frame is not a frame of the model; the shell names it and the frames
    /// that exist).
    Frame,
    /// NaN or ±Inf in `field[index]`.
    NonFinite { field: Field, index: usize },
    /// The quaternion's squared norm is this far from 1 (more than 0.01, tf2's tolerance).
    NotUnitQuaternion { norm: f64 },
    /// `position[axis] = value` is outside the workspace box `[min, max]`.
    OutsideWorkspace { axis: usize, value: f64, min: f64, max: f64 },
    /// The stamp is older than the target already taken.
    OutOfOrder { stamp: f64, last: f64 },
    /// The force along the force axis is outside `[min, max]` (pushing positive).
    ForceOutOfRange { value: f64, min: f64, max: f64 },
}

impl std::fmt::Display for Rejection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        const AXES: [&str; 3] = ["x", "y", "z"];
        match *self {
            Rejection::Frame => write!(f, "header.frame_id is not a frame of the robot model: use the base frame ('' or its name) or a link or joint of the URDF"),
            Rejection::NonFinite { field, index } => write!(f, "{}[{index}] is not finite (NaN or Inf)", field.as_str()),
            Rejection::NotUnitQuaternion { norm } => {
                write!(f, "pose.orientation has norm {norm:.4}, not 1: send a unit quaternion (x, y, z, w); identity is (0, 0, 0, 1)")
            }
            Rejection::OutsideWorkspace { axis, value, min, max } => write!(
                f,
                "pose.position.{} = {value:.4} m is outside the workspace [{min:.4}, {max:.4}] m (check units: metres)",
                AXES[axis.min(2)]
            ),
            Rejection::OutOfOrder { stamp, last } => {
                write!(f, "header.stamp {stamp:.6} s is older than the last target's {last:.6} s")
            }
            Rejection::ForceOutOfRange { value, min, max } => write!(
                f,
                "force along the force axis {value:.3} N is outside [{min}, {max}] N (the wrench the tool applies, pushing positive)"
            ),
        }
    }
}

fn finite(field: Field, v: &[f64]) -> Result<(), Rejection> {
    match v.iter().position(|x| !x.is_finite()) {
        Some(index) => Err(Rejection::NonFinite { field, index }),
        None => Ok(()),
    }
}

/// Axis-aligned box in the base frame the target position must lie in [m].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Workspace {
    pub min: Vector3<f64>,
    pub max: Vector3<f64>,
}

impl TargetPose<'_> {
    /// The checked target: position and unit orientation.
    pub fn check(&self, base_frame: &str, ws: &Workspace) -> Result<(Vector3<f64>, UnitQuaternion<f64>), Rejection> {
        if self.frame_id != base_frame {
            return Err(Rejection::Frame);
        }
        finite(Field::Stamp, &[self.stamp])?;
        finite(Field::Position, &self.position)?;
        finite(Field::Orientation, &self.orientation)?;
        let [x, y, z, w] = self.orientation;
        let q = Quaternion::new(w, x, y, z);
        let n2 = q.norm_squared();
        if (n2 - 1.0).abs() > 0.01 {
            return Err(Rejection::NotUnitQuaternion { norm: n2.sqrt() });
        }
        let p = Vector3::from(self.position);
        for axis in 0..3 {
            if !(p[axis] >= ws.min[axis] && p[axis] <= ws.max[axis]) {
                return Err(Rejection::OutsideWorkspace { axis, value: p[axis], min: ws.min[axis], max: ws.max[axis] });
            }
        }
        Ok((p, UnitQuaternion::new_normalize(q)))
    }
}

impl DesiredWrench<'_> {
    /// The checked force along the unit direction `n` (pushing positive) [N].
    pub fn check(&self, base_frame: &str, n: &Vector3<f64>, min: f64, max: f64) -> Result<f64, Rejection> {
        if self.frame_id != base_frame {
            return Err(Rejection::Frame);
        }
        finite(Field::Stamp, &[self.stamp])?;
        finite(Field::Force, &self.force)?;
        finite(Field::Torque, &self.torque)?;
        let f = Vector3::from(self.force).dot(n);
        if !(f >= min && f <= max) {
            return Err(Rejection::ForceOutOfRange { value: f, min, max });
        }
        Ok(f)
    }
}
