//! Message types on the wire (from `naic_msgs`) and their ROS (package, Type) names for
//! topic creation.

pub use naic_msgs::{
    Clock, Float64MultiArray, Header, JointState, MultiArrayDimension, MultiArrayLayout, Point, Pose, PoseStamped, Quaternion,
    NaicParams, Time, Vector3, Wrench, WrenchStamped,
};

use naic_core::{JointVec, N_JOINTS};

pub const JOINT_STATE: (&str, &str) = ("sensor_msgs", "JointState");
pub const WRENCH_STAMPED: (&str, &str) = ("geometry_msgs", "WrenchStamped");
pub const POSE_STAMPED: (&str, &str) = ("geometry_msgs", "PoseStamped");
pub const FLOAT64_MULTI_ARRAY: (&str, &str) = ("std_msgs", "Float64MultiArray");
pub const CLOCK: (&str, &str) = ("rosgraph_msgs", "Clock");
pub const NAIC_PARAMS: (&str, &str) = ("naic_msgs", "NaicParams");

/// Joint names of the JK5 in joint order, as published on `/joint_states`.
pub const JOINT_NAMES: [&str; N_JOINTS] = ["joint1", "joint2", "joint3", "joint4", "joint5", "joint6"];

/// A torque command `std_msgs/Float64MultiArray` with one dimension `joints` of size n.
///
/// Tracing: when `source_stamp_ns` is given, the dimension label reads
/// `joints;stamp_ns=<ns>`: the stamp of the `/joint_states` sample the command was computed
/// from. Consumers that only read `data` are unaffected; the driver uses it to measure the
/// chain latency (`naic bench chain`).
pub fn effort_msg(tau: &[f64], source_stamp_ns: Option<i64>) -> Float64MultiArray {
    let mut m = Float64MultiArray::default();
    set_effort_msg(&mut m, tau, source_stamp_ns);
    m
}

/// [`effort_msg`] written into `m` in place: once `m`'s label and data have reached their
/// size (the first cycle), this allocates nothing. ros2-client's `Publisher::publish`
/// takes the message by value, so the shells publish a clone of this buffer: that clone
/// (the label `String`, the dimension and data `Vec`s) is the one allocation per
/// published message the API forces.
pub fn set_effort_msg(m: &mut Float64MultiArray, tau: &[f64], source_stamp_ns: Option<i64>) {
    use std::fmt::Write;
    if m.layout.dim.len() != 1 {
        m.layout.dim.clear();
        m.layout.dim.push(MultiArrayDimension::default());
    }
    let d = &mut m.layout.dim[0];
    d.label.clear();
    d.label.push_str("joints");
    if let Some(ns) = source_stamp_ns {
        let _ = write!(d.label, ";stamp_ns={ns}");
    }
    d.size = tau.len() as u32;
    d.stride = tau.len() as u32;
    m.layout.data_offset = 0;
    m.data.clear();
    m.data.extend_from_slice(tau);
}

/// The `/joint_states` stamp a command was computed from, if it carries one.
pub fn effort_source_stamp(m: &Float64MultiArray) -> Option<i64> {
    let label = &m.layout.dim.first()?.label;
    label.split(';').find_map(|kv| kv.strip_prefix("stamp_ns=")).and_then(|v| v.parse().ok())
}

/// Why a torque command was refused (allocation-free; `Display` gives the message).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EffortError {
    /// Fewer than six values after `data_offset`.
    TooFew(usize),
    /// A NaN or ±Inf among the six.
    NonFinite(f64),
}

impl std::fmt::Display for EffortError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            EffortError::TooFew(n) => write!(f, "torque command needs {N_JOINTS} values (joint1..joint6, N m), got {n}"),
            EffortError::NonFinite(v) => write!(f, "torque command contains a non-finite value ({v})"),
        }
    }
}

/// Check a 6-joint torque command: six finite numbers, data_offset 0.
pub fn effort_values(m: &Float64MultiArray, out: &mut JointVec) -> Result<(), EffortError> {
    let off = m.layout.data_offset as usize;
    if m.data.len() < off + N_JOINTS {
        return Err(EffortError::TooFew(m.data.len().saturating_sub(off)));
    }
    for (o, v) in out.iter_mut().zip(&m.data[off..off + N_JOINTS]) {
        if !v.is_finite() {
            return Err(EffortError::NonFinite(*v));
        }
        *o = *v;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn stamp_label_round_trip() {
        let m = effort_msg(&[1.0; 6], Some(1_700_000_000_000_000_123));
        assert_eq!(effort_source_stamp(&m), Some(1_700_000_000_000_000_123));
        assert_eq!(effort_source_stamp(&effort_msg(&[0.0; 6], None)), None);
        let mut t = [0.0; 6];
        effort_values(&m, &mut t).unwrap();
        assert_eq!(t, [1.0; 6]);
        let mut bad = m.clone();
        bad.data[2] = f64::NAN;
        assert!(effort_values(&bad, &mut t).unwrap_err().to_string().contains("non-finite"));
        bad.data.truncate(3);
        assert!(effort_values(&bad, &mut t).unwrap_err().to_string().contains("needs 6 values"));
    }

    #[test]
    fn the_effort_buffer_is_rewritten_without_allocating() {
        let mut m = effort_msg(&[0.0; 6], Some(i64::MAX));
        let (_, n) = crate::alloc_check::counted(|| set_effort_msg(&mut m, &[2.0; 6], Some(1_700_000_000_000_000_123)));
        assert_eq!(n, 0);
        assert_eq!(m, effort_msg(&[2.0; 6], Some(1_700_000_000_000_000_123)));
        set_effort_msg(&mut m, &[3.0; 6], None);
        assert_eq!(m, effort_msg(&[3.0; 6], None));
    }
}
