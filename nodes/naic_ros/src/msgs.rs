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
