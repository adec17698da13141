//! ROS 2 message types used by naic, with the exact field layout of their `.msg` files.
//!
//! Each type derives serde `Serialize`/`Deserialize` with fields in `.msg` order, which is
//! its CDR codec: ros2-client puts it on the wire through `cdr-encoding`, and [`cdr`] uses
//! the same crate for the bag reader and writer. [`RosMessage`] gives the full
//! ROS type name, the rosbag2 MCAP schema text ([`schema_text`]) and the REP-2011 type
//! hash ([`type_hash`], `RIHS01_…`).

pub mod cdr;
pub mod rcl;
mod copy;
mod describe;
mod types;

pub use cdr::{CdrDecode, CdrEncode, CdrError};
pub use copy::CopyFrom;
pub use describe::{schema_text, type_description_json, type_hash, FieldInfo, FieldType, TypeInfo};
pub use types::*;

/// A ROS 2 message type.
pub trait RosMessage: CdrEncode + CdrDecode + Clone + 'static {
    /// Field list, `.msg` text and name of the type.
    fn type_info() -> &'static TypeInfo;

    /// Full ROS type name, e.g. `sensor_msgs/msg/JointState`.
    fn type_name() -> &'static str {
        Self::type_info().name
    }

    /// Serializes with the CDR encapsulation header.
    fn to_cdr(&self) -> Vec<u8> {
        cdr::encode(self)
    }

    /// Deserializes a complete CDR message (encapsulation header included).
    fn from_cdr(data: &[u8]) -> Result<Self, CdrError> {
        cdr::decode(data)
    }
}
