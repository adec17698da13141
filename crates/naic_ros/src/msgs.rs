//! Message types on the wire (from `naic_msgs`) and their ROS (package, Type) names for
//! topic creation.

pub use naic_msgs::{
    Clock, Float64MultiArray, Header, JointState, MultiArrayDimension, MultiArrayLayout, Point, Pose, PoseStamped, Quaternion,
    NaicParams, StringMsg, TFMessage, Time, Transform, TransformStamped, Vector3, Wrench, WrenchStamped,
};

use naic_core::{JointVec, N_JOINTS};

/// Announce the RIHS01 type hash (REP-2011, computed by `naic_msgs` from the field lists)
/// of every message type naic publishes or subscribes in the USER_DATA of its DDS endpoints
/// (`typehash=RIHS01_…;`, as rmw_fastrtps does in Jazzy; the vendored rustdds's patch), so
/// `ros2 topic info -v` shows a valid hash. Call before creating endpoints.
pub fn register_type_hashes() {
    use naic_msgs::RosMessage;
    fn one<M: RosMessage>() {
        let full = M::type_name(); // pkg/msg/Type
        let mut parts = full.split('/');
        if let (Some(pkg), Some(_), Some(ty)) = (parts.next(), parts.next(), parts.next()) {
            let hash = naic_msgs::type_hash(M::type_info());
            ros2_client::dds::rustdds::register_type_hash(&format!("{pkg}::msg::dds_::{ty}_"), &hash);
        }
    }
    one::<JointState>();
    one::<WrenchStamped>();
    one::<PoseStamped>();
    one::<Float64MultiArray>();
    one::<Clock>();
    one::<NaicParams>();
    one::<StringMsg>();
    one::<TFMessage>();
    // The types ros2-client publishes itself (/rosout, /parameter_events).
    for info in [naic_msgs::rcl::log(), naic_msgs::rcl::parameter_event()] {
        if let Some((pkg, ty)) = info.name.split_once("/msg/") {
            ros2_client::dds::rustdds::register_type_hash(&format!("{pkg}::msg::dds_::{ty}_"), &naic_msgs::type_hash(info));
        }
    }
}

pub const JOINT_STATE: (&str, &str) = ("sensor_msgs", "JointState");
pub const WRENCH_STAMPED: (&str, &str) = ("geometry_msgs", "WrenchStamped");
pub const POSE_STAMPED: (&str, &str) = ("geometry_msgs", "PoseStamped");
pub const FLOAT64_MULTI_ARRAY: (&str, &str) = ("std_msgs", "Float64MultiArray");
pub const CLOCK: (&str, &str) = ("rosgraph_msgs", "Clock");
pub const NAIC_PARAMS: (&str, &str) = ("naic_msgs", "NaicParams");
pub const STRING: (&str, &str) = ("std_msgs", "String");
pub const TF_MESSAGE: (&str, &str) = ("tf2_msgs", "TFMessage");

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
    set_effort_msg(&mut m, tau, source_stamp_ns, None);
    m
}

/// The label of the first dimension of a `/naic/effort` that also carries the friction
/// feedforward's joint velocity (2 × N: torques, then velocities).
const EFFORT_AND_VELOCITY: &str = "effort,friction_velocity";

/// [`effort_msg`] written into `m` in place: once `m`'s label and data have reached their
/// size (the first cycle), this allocates nothing. ros2-client's `Publisher::publish`
/// takes the message by value, so the shells publish a clone of this buffer: that clone
/// (the label `String`, the dimension and data `Vec`s) is the one allocation per
/// published message the API forces.
///
/// With `friction_velocity` (the controller's `ControlOutputs::dq_ff`, the scheduled law's
/// velocity for the friction feedforward) the array is 2 × N for an N-joint arm: dimension 0
/// `effort,friction_velocity` (size 2, stride 2N), dimension 1 `joints` (size N, stride N),
/// the torques first. A reader of N torques ([`effort_values`]) reads the first row as
/// before; the friction node reads the second with [`effort_friction_velocity`].
pub fn set_effort_msg(m: &mut Float64MultiArray, tau: &[f64], source_stamp_ns: Option<i64>, friction_velocity: Option<&[f64]>) {
    use std::fmt::Write;
    let dims = if friction_velocity.is_some() { 2 } else { 1 };
    if m.layout.dim.len() != dims {
        m.layout.dim.resize(dims, MultiArrayDimension::default());
    }
    let n = tau.len() as u32;
    let d = &mut m.layout.dim[0];
    d.label.clear();
    // Sized once for the longest label (no regrowth as the stamp gains digits).
    d.label.reserve(EFFORT_LABEL_CAPACITY);
    d.label.push_str(if dims == 2 { EFFORT_AND_VELOCITY } else { "joints" });
    if let Some(ns) = source_stamp_ns {
        let _ = write!(d.label, ";stamp_ns={ns}");
    }
    d.size = if dims == 2 { 2 } else { n };
    d.stride = dims as u32 * n;
    if dims == 2 {
        let j = &mut m.layout.dim[1];
        j.label.clear();
        j.label.push_str("joints");
        j.size = n;
        j.stride = n;
    }
    m.layout.data_offset = 0;
    m.data.clear();
    m.data.extend_from_slice(tau);
    if let Some(v) = friction_velocity {
        m.data.extend_from_slice(v);
    }
}

/// A `/naic/effort` buffer that stays allocation-free when the message changes between one
/// row (torques) and two (torques and the friction feedforward's velocity, [`set_effort_msg`]):
/// it is sized for two rows of `n` joints and a stamp of any length when made, and keeps the
/// second dimension aside while the message has one row, so that a law that starts giving
/// a velocity mid-run (the scheduled law, once the tare is done) does not grow the message
/// in the 1 kHz path.
pub struct EffortBuffer {
    pub msg: Float64MultiArray,
    spare: Option<MultiArrayDimension>,
}

/// The longest first-dimension label [`set_effort_msg`] writes: the two-row label and
/// `;stamp_ns=` with an i64 (20 characters with its sign).
const EFFORT_LABEL_CAPACITY: usize = EFFORT_AND_VELOCITY.len() + ";stamp_ns=".len() + 20;

impl EffortBuffer {
    pub fn new(n: usize) -> Self {
        let mut msg = Float64MultiArray::default();
        msg.layout.dim.reserve_exact(2);
        msg.layout.dim.push(MultiArrayDimension { label: String::with_capacity(EFFORT_LABEL_CAPACITY), ..Default::default() });
        msg.data.reserve_exact(2 * n);
        let spare = MultiArrayDimension { label: String::with_capacity("joints".len()), ..Default::default() };
        Self { msg, spare: Some(spare) }
    }

    /// [`set_effort_msg`] into the buffer, without allocating once made for this `n`.
    pub fn set(&mut self, tau: &[f64], source_stamp_ns: Option<i64>, friction_velocity: Option<&[f64]>) {
        let dim = &mut self.msg.layout.dim;
        match (friction_velocity.is_some(), dim.len()) {
            (true, 1) => dim.push(self.spare.take().unwrap_or_default()),
            (false, 2) => self.spare = dim.pop(),
            _ => {}
        }
        set_effort_msg(&mut self.msg, tau, source_stamp_ns, friction_velocity);
    }
}

/// The joint velocity a `/naic/effort` names for the friction feedforward (its second row,
/// [`set_effort_msg`]) into `out`: `Ok(false)` when it carries torques only (evaluate at
/// the measured velocity), an error when the second row is short or not finite.
pub fn effort_friction_velocity<const N: usize>(m: &Float64MultiArray, out: &mut JointVec<N>) -> Result<bool, EffortError> {
    let two_rows = m.layout.dim.len() == 2
        && m.layout.dim[0].size == 2
        && m.layout.dim[0].label.split(';').next() == Some(EFFORT_AND_VELOCITY);
    if !two_rows {
        return Ok(false);
    }
    n_finite(&m.data, m.layout.data_offset as usize + N, out)?;
    Ok(true)
}

/// The `/joint_states` stamp a command was computed from, if it carries one.
pub fn effort_source_stamp(m: &Float64MultiArray) -> Option<i64> {
    let label = &m.layout.dim.first()?.label;
    label.split(';').find_map(|kv| kv.strip_prefix("stamp_ns=")).and_then(|v| v.parse().ok())
}

/// Why a torque command was refused (allocation-free; `Display` gives the message).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EffortError {
    /// Fewer than `need` (the arm's joint count) values after `data_offset`: `got`.
    TooFew { need: usize, got: usize },
    /// A NaN or ±Inf among the N.
    NonFinite(f64),
}

impl std::fmt::Display for EffortError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            EffortError::TooFew { need, got } => write!(f, "torque command needs {need} values (one per joint of the arm in its `joints` order, N m), got {got}"),
            EffortError::NonFinite(v) => write!(f, "torque command contains a non-finite value ({v})"),
        }
    }
}

/// Check an N-joint torque command: N finite numbers from data_offset.
pub fn effort_values<const N: usize>(m: &Float64MultiArray, out: &mut JointVec<N>) -> Result<(), EffortError> {
    n_finite(&m.data, m.layout.data_offset as usize, out)
}

/// `data[off..off + N]` into `out` when all N are there and finite.
fn n_finite<const N: usize>(data: &[f64], off: usize, out: &mut JointVec<N>) -> Result<(), EffortError> {
    if data.len() < off + N {
        return Err(EffortError::TooFew { need: N, got: data.len().saturating_sub(off) });
    }
    for (o, v) in out.iter_mut().zip(&data[off..off + N]) {
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

    /// The controller's `/naic/effort` buffer: one row, two rows, one again, with stamps of
    /// every length, allocates nothing once made (the 1 kHz path of the scheduled law,
    /// which gives the friction velocity only once the tare is done).
    #[test]
    fn the_effort_buffer_changes_rows_without_allocating() {
        let mut b = EffortBuffer::new(7);
        let (tau, v) = ([1.0; 7], [0.5; 7]);
        let ((), n) = crate::alloc_check::counted(|| {
            for (k, stamp) in [0_i64, 9, 1_000_000_000, i64::MAX, i64::MIN].into_iter().enumerate() {
                b.set(&tau, Some(stamp), None);
                b.set(&tau, Some(stamp), Some(&v));
                b.set(&tau, if k % 2 == 0 { None } else { Some(stamp) }, Some(&v));
                b.set(&tau, Some(stamp), None);
            }
        });
        assert_eq!(n, 0, "allocations");
        b.set(&tau, Some(42), Some(&v));
        assert_eq!((b.msg.layout.dim.len(), b.msg.data.len()), (2, 14));
        let mut out = [0.0; 7];
        assert!(effort_friction_velocity::<7>(&b.msg, &mut out).unwrap());
        assert_eq!((out, effort_source_stamp(&b.msg)), ([0.5; 7], Some(42)));
        b.set(&tau, Some(43), None);
        assert_eq!((b.msg.layout.dim.len(), b.msg.data.len()), (1, 7));
        assert!(!effort_friction_velocity::<7>(&b.msg, &mut out).unwrap());
        assert_eq!(b.msg, effort_msg(&tau, Some(43)), "the same message as a fresh one");
    }

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
        let (_, n) = crate::alloc_check::counted(|| set_effort_msg(&mut m, &[2.0; 6], Some(1_700_000_000_000_000_123), None));
        assert_eq!(n, 0);
        assert_eq!(m, effort_msg(&[2.0; 6], Some(1_700_000_000_000_000_123)));
        set_effort_msg(&mut m, &[3.0; 6], None, None);
        assert_eq!(m, effort_msg(&[3.0; 6], None));
    }

    #[test]
    fn the_friction_velocity_travels_as_a_second_row() {
        let v = [0.1, -0.2, 0.0, 0.3, 0.004, -0.5];
        let mut m = effort_msg(&[0.0; 6], None);
        set_effort_msg(&mut m, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0], Some(42), Some(&v));
        assert_eq!(m.data.len(), 12);
        assert_eq!((m.layout.dim[0].size, m.layout.dim[0].stride, m.layout.dim[1].size), (2, 12, 6));
        // Readers of the torques and of the stamp see what they saw before.
        let mut t = [0.0; 6];
        effort_values(&m, &mut t).unwrap();
        assert_eq!(t, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        assert_eq!(effort_source_stamp(&m), Some(42));
        let mut got = [9.0; 6];
        assert_eq!(effort_friction_velocity(&m, &mut got), Ok(true));
        assert_eq!(got, v);
        // Rewritten in place without allocating once at size.
        let (_, n) = crate::alloc_check::counted(|| set_effort_msg(&mut m, &[2.0; 6], Some(43), Some(&v)));
        assert_eq!(n, 0);
        // Torques only: no velocity named.
        assert_eq!(effort_friction_velocity(&effort_msg(&[1.0; 6], Some(1)), &mut got), Ok(false));
        // A second row that is short or not finite is refused, naming the problem.
        let mut bad = m.clone();
        bad.data[8] = f64::INFINITY;
        assert!(effort_friction_velocity(&bad, &mut got).unwrap_err().to_string().contains("non-finite"));
        bad.data.truncate(9);
        assert!(matches!(effort_friction_velocity(&bad, &mut got), Err(EffortError::TooFew { need: 6, got: 3 })));
        // Back to one row.
        set_effort_msg(&mut m, &[3.0; 6], None, None);
        assert_eq!(m, effort_msg(&[3.0; 6], None));
    }
}
