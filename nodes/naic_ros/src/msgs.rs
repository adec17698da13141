//! Message types on the wire (from `naic_msgs`) and their ROS (package, Type) names for
//! topic creation.

pub use naic_msgs::{
    Clock, Float64MultiArray, Header, JointState, MultiArrayDimension, MultiArrayLayout,
    NaicParams, Time, Vector3, Wrench, WrenchStamped,
};

pub const JOINT_STATE: (&str, &str) = ("sensor_msgs", "JointState");
pub const WRENCH_STAMPED: (&str, &str) = ("geometry_msgs", "WrenchStamped");
pub const FLOAT64_MULTI_ARRAY: (&str, &str) = ("std_msgs", "Float64MultiArray");
pub const CLOCK: (&str, &str) = ("rosgraph_msgs", "Clock");
pub const NAIC_PARAMS: (&str, &str) = ("naic_msgs", "NaicParams");

/// Joint names of the JK5 in joint order, as published on `/joint_states`.
pub const JOINT_NAMES: [&str; 6] = ["joint1", "joint2", "joint3", "joint4", "joint5", "joint6"];

/// A torque command `std_msgs/Float64MultiArray` with one dimension `joints` of size n.
///
/// Tracing: when `source_stamp_ns` is given, the dimension label reads
/// `joints;stamp_ns=<ns>`: the stamp of the `/joint_states` sample the command was computed
/// from. Consumers that only read `data` are unaffected; the driver uses it to measure the
/// chain latency (`naic bench chain`).
pub fn effort_msg(tau: &[f64], source_stamp_ns: Option<i64>) -> Float64MultiArray {
    let label = match source_stamp_ns {
        Some(ns) => format!("joints;stamp_ns={ns}"),
        None => "joints".to_string(),
    };
    Float64MultiArray {
        layout: MultiArrayLayout {
            dim: vec![MultiArrayDimension { label, size: tau.len() as u32, stride: tau.len() as u32 }],
            data_offset: 0,
        },
        data: tau.to_vec(),
    }
}

/// The `/joint_states` stamp a command was computed from, if it carries one.
pub fn effort_source_stamp(m: &Float64MultiArray) -> Option<i64> {
    let label = &m.layout.dim.first()?.label;
    label.split(';').find_map(|kv| kv.strip_prefix("stamp_ns=")).and_then(|v| v.parse().ok())
}

/// Check a 6-joint torque command: six finite numbers, data_offset 0.
pub fn effort_values(m: &Float64MultiArray, out: &mut [f64; 6]) -> Result<(), String> {
    let off = m.layout.data_offset as usize;
    if m.data.len() < off + 6 {
        return Err(format!(
            "torque command needs 6 values (joint1..joint6, N m), got {}",
            m.data.len().saturating_sub(off)
        ));
    }
    for (o, v) in out.iter_mut().zip(&m.data[off..off + 6]) {
        if !v.is_finite() {
            return Err(format!("torque command contains a non-finite value ({v})"));
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
        assert!(effort_values(&bad, &mut t).unwrap_err().contains("non-finite"));
        bad.data.truncate(3);
        assert!(effort_values(&bad, &mut t).unwrap_err().contains("needs 6 values"));
    }
}
