//! The message structs. Field order and types follow the `.msg` files exactly
//! (checked against rosidl's type descriptions and rclpy's CDR in the tests).

use crate::describe::{FieldInfo, FieldType, TypeInfo};
use crate::RosMessage;
use serde::{Deserialize, Serialize};

/// Defines a message struct (serde in field order, which is its CDR codec: see [`crate::cdr`])
/// and its type description from one field list.
macro_rules! ros_message {
    (
        $(#[$meta:meta])*
        $name:ident = $full:literal, msg: $text:expr,
        { $( $(#[$fmeta:meta])* $field:ident : $ty:ty ),* $(,)? }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
        pub struct $name {
            $( $(#[$fmeta])* pub $field: $ty, )*
        }

        impl crate::CopyFrom for $name {
            fn copy_from(&mut self, _src: &Self) {
                $( crate::CopyFrom::copy_from(&mut self.$field, &_src.$field); )*
            }
        }

        impl FieldType for $name {
            const TYPE_ID: u8 = 1; // FIELD_TYPE_NESTED_TYPE
            const NESTED: Option<fn() -> &'static TypeInfo> = Some(<$name as RosMessage>::type_info);
        }

        impl FieldType for Vec<$name> {
            const TYPE_ID: u8 = 145; // FIELD_TYPE_NESTED_TYPE_UNBOUNDED_SEQUENCE
            const NESTED: Option<fn() -> &'static TypeInfo> = Some(<$name as RosMessage>::type_info);
        }

        impl RosMessage for $name {
            fn type_info() -> &'static TypeInfo {
                static INFO: TypeInfo = TypeInfo {
                    name: $full,
                    msg_text: $text,
                    fields: &[ $( FieldInfo {
                        name: stringify!($field),
                        type_id: <$ty as FieldType>::TYPE_ID,
                        nested: <$ty as FieldType>::NESTED,
                    } ),* ],
                };
                &INFO
            }
        }
    };
}

ros_message! {
    /// `builtin_interfaces/msg/Time`: seconds and nanoseconds since the epoch (or sim start).
    Time = "builtin_interfaces/msg/Time", msg: "int32 sec\nuint32 nanosec\n",
    { sec: i32, nanosec: u32 }
}

impl Time {
    /// From nanoseconds (negative times floor to the previous second, as rclpy does).
    pub fn from_nanos(ns: i64) -> Self {
        Self { sec: ns.div_euclid(1_000_000_000) as i32, nanosec: ns.rem_euclid(1_000_000_000) as u32 }
    }
    pub fn to_nanos(&self) -> i64 {
        self.sec as i64 * 1_000_000_000 + self.nanosec as i64
    }
}

ros_message! {
    /// `std_msgs/msg/Header`.
    Header = "std_msgs/msg/Header", msg: "builtin_interfaces/Time stamp\nstring frame_id\n",
    { stamp: Time, frame_id: String }
}

ros_message! {
    /// `sensor_msgs/msg/JointState`.
    JointState = "sensor_msgs/msg/JointState",
    msg: "std_msgs/Header header\n\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n",
    { header: Header, name: Vec<String>, position: Vec<f64>, velocity: Vec<f64>, effort: Vec<f64> }
}

ros_message! {
    /// `geometry_msgs/msg/Vector3`.
    Vector3 = "geometry_msgs/msg/Vector3", msg: "float64 x\nfloat64 y\nfloat64 z\n",
    { x: f64, y: f64, z: f64 }
}

ros_message! {
    /// `geometry_msgs/msg/Wrench`: force [N] and torque [N m].
    Wrench = "geometry_msgs/msg/Wrench", msg: "Vector3 force\nVector3 torque\n",
    { force: Vector3, torque: Vector3 }
}

ros_message! {
    /// `geometry_msgs/msg/WrenchStamped`.
    WrenchStamped = "geometry_msgs/msg/WrenchStamped", msg: "std_msgs/Header header\nWrench wrench\n",
    { header: Header, wrench: Wrench }
}

ros_message! {
    /// `geometry_msgs/msg/Point` [m].
    Point = "geometry_msgs/msg/Point", msg: "float64 x\nfloat64 y\nfloat64 z\n",
    { x: f64, y: f64, z: f64 }
}

ros_message! {
    /// `geometry_msgs/msg/Quaternion` (x, y, z, w). ROS's default is the identity (w = 1);
    /// the derived `Default` here is all zeros: set `w` yourself.
    Quaternion = "geometry_msgs/msg/Quaternion", msg: "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n",
    { x: f64, y: f64, z: f64, w: f64 }
}

ros_message! {
    /// `geometry_msgs/msg/Pose`.
    Pose = "geometry_msgs/msg/Pose", msg: "Point position\nQuaternion orientation\n",
    { position: Point, orientation: Quaternion }
}

ros_message! {
    /// `geometry_msgs/msg/PoseStamped` (`/naic/target_pose`).
    PoseStamped = "geometry_msgs/msg/PoseStamped", msg: "std_msgs/Header header\nPose pose\n",
    { header: Header, pose: Pose }
}

ros_message! {
    /// `geometry_msgs/msg/Transform`: translation [m] and rotation (unit quaternion).
    Transform = "geometry_msgs/msg/Transform", msg: "Vector3 translation\nQuaternion rotation\n",
    { translation: Vector3, rotation: Quaternion }
}

ros_message! {
    /// `geometry_msgs/msg/TransformStamped`: `child_frame_id`'s pose in `header.frame_id`.
    TransformStamped = "geometry_msgs/msg/TransformStamped",
    msg: "std_msgs/Header header\nstring child_frame_id\nTransform transform\n",
    { header: Header, child_frame_id: String, transform: Transform }
}

ros_message! {
    /// `tf2_msgs/msg/TFMessage` (`/tf`, `/tf_static`).
    TFMessage = "tf2_msgs/msg/TFMessage", msg: "geometry_msgs/TransformStamped[] transforms\n",
    { transforms: Vec<TransformStamped> }
}

ros_message! {
    /// `std_msgs/msg/MultiArrayDimension`.
    MultiArrayDimension = "std_msgs/msg/MultiArrayDimension",
    msg: "string label\nuint32 size\nuint32 stride\n",
    { label: String, size: u32, stride: u32 }
}

ros_message! {
    /// `std_msgs/msg/MultiArrayLayout`.
    MultiArrayLayout = "std_msgs/msg/MultiArrayLayout",
    msg: "MultiArrayDimension[] dim\nuint32 data_offset\n",
    { dim: Vec<MultiArrayDimension>, data_offset: u32 }
}

ros_message! {
    /// `std_msgs/msg/Float64MultiArray`.
    Float64MultiArray = "std_msgs/msg/Float64MultiArray",
    msg: "MultiArrayLayout layout\nfloat64[] data\n",
    { layout: MultiArrayLayout, data: Vec<f64> }
}

ros_message! {
    /// `rosgraph_msgs/msg/Clock`.
    Clock = "rosgraph_msgs/msg/Clock", msg: "builtin_interfaces/Time clock\n",
    { clock: Time }
}

ros_message! {
    /// `std_msgs/msg/String` (`/robot_description`: the URDF text).
    StringMsg = "std_msgs/msg/String", msg: "string data\n",
    { data: String }
}

ros_message! {
    /// `naic_msgs/msg/NaicParams`: the controller state published every cycle on `/naic/params`
    /// (field meanings in `msgs/naic_msgs/msg/NaicParams.msg`).
    NaicParams = "naic_msgs/msg/NaicParams",
    msg: include_str!("../../naic_msgs/msg/NaicParams.msg"),
    {
        header: Header,
        mode: String,
        phase: u8,
        force_axis: u8,
        desired_force: f64,
        measured_force: f64,
        e_f: f64,
        m_d: f64,
        b_d: f64,
        k_d: f64,
        sigma: f64,
        phi: f64,
        gamma: f64,
        gamma_bound: f64,
        gamma_clipped: bool,
        fault: String,
        fault_count: u32,
        reference_source: String,
        reference_position: Vec<f64>,
        reference_stale: bool,
        reference_rejected: u32,
        k_e_hat: f64,
        k_e_confidence: f64,
        model_gain: f64,
        gravity_scale: f64,
        wrench_bias: Vec<f64>,
    }
}

impl NaicParams {
    pub const PHASE_FREE: u8 = 0;
    pub const PHASE_CONTACT: u8 = 1;
    pub const PHASE_HOLD: u8 = 2;
}
