//! Message types on the wire and their ROS type names.
//!
//! SCRATCH: minimal local copies until the `naic_msgs` crate (msgs/rust) lands on main;
//! then this module re-exports it and keeps only the type-name table.

use serde::{Deserialize, Serialize};

/// `builtin_interfaces/Time`
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Time {
    pub sec: i32,
    pub nanosec: u32,
}

/// `std_msgs/Header`
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    pub stamp: Time,
    pub frame_id: String,
}

/// `sensor_msgs/JointState`
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct JointState {
    pub header: Header,
    pub name: Vec<String>,
    pub position: Vec<f64>,
    pub velocity: Vec<f64>,
    pub effort: Vec<f64>,
}

/// `geometry_msgs/Vector3`
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

/// `geometry_msgs/Wrench`
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Wrench {
    pub force: Vector3,
    pub torque: Vector3,
}

/// `geometry_msgs/WrenchStamped`
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct WrenchStamped {
    pub header: Header,
    pub wrench: Wrench,
}

/// `std_msgs/MultiArrayDimension`
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MultiArrayDimension {
    pub label: String,
    pub size: u32,
    pub stride: u32,
}

/// `std_msgs/MultiArrayLayout`
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MultiArrayLayout {
    pub dim: Vec<MultiArrayDimension>,
    pub data_offset: u32,
}

/// `std_msgs/Float64MultiArray`
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Float64MultiArray {
    pub layout: MultiArrayLayout,
    pub data: Vec<f64>,
}

/// `rosgraph_msgs/Clock`
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Clock {
    pub clock: Time,
}

/// `naic_msgs/NaicParams` (msgs/naic_msgs/msg/NaicParams.msg, same field order)
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct NaicParams {
    pub header: Header,
    pub mode: String,
    pub phase: u8,
    pub force_axis: u8,
    pub desired_force: f64,
    pub measured_force: f64,
    pub e_f: f64,
    pub m_d: f64,
    pub b_d: f64,
    pub k_d: f64,
    pub sigma: f64,
    pub phi: f64,
    pub gamma: f64,
    pub gamma_bound: f64,
    pub gamma_clipped: bool,
    pub fault: String,
    pub fault_count: u32,
}
