//! Type descriptions of the `rcl_interfaces` messages ros2-client publishes itself on
//! `/rosout` (`Log`) and `/parameter_events` (`ParameterEvent`), for their RIHS01 type
//! hashes in discovery (`ros2 topic info -v`). Descriptions only: ros2-client has the
//! structs. `ParameterValue` has `byte[]` and `bool[]` fields, which no Rust field type of
//! [`crate::types`] maps to, so these are written out here, field by field as in the `.msg`
//! files.

use crate::describe::{FieldInfo, TypeInfo};
use crate::{RosMessage, Time};

fn time() -> &'static TypeInfo {
    <Time as RosMessage>::type_info()
}

const fn field(name: &'static str, type_id: u8) -> FieldInfo {
    FieldInfo { name, type_id, nested: None }
}

const fn nested(name: &'static str, type_id: u8, t: fn() -> &'static TypeInfo) -> FieldInfo {
    FieldInfo { name, type_id, nested: Some(t) }
}

// type_description_interfaces/msg/FieldType ids.
const NESTED: u8 = 1;
const NESTED_SEQ: u8 = 145;
const UINT8: u8 = 3;
const UINT32: u8 = 7;
const INT64: u8 = 8;
const DOUBLE: u8 = 11;
const BOOL: u8 = 15;
const STRING: u8 = 17;
const BOOL_SEQ: u8 = 15 + 144;
const BYTE_SEQ: u8 = 16 + 144;
const INT64_SEQ: u8 = 8 + 144;
const DOUBLE_SEQ: u8 = 11 + 144;
const STRING_SEQ: u8 = 17 + 144;

/// `rcl_interfaces/msg/Log` (`/rosout`).
pub fn log() -> &'static TypeInfo {
    static INFO: TypeInfo = TypeInfo {
        name: "rcl_interfaces/msg/Log",
        msg_text: "builtin_interfaces/Time stamp\nuint8 level\nstring name\nstring msg\nstring file\nstring function\nuint32 line\n",
        fields: &[
            nested("stamp", NESTED, time),
            field("level", UINT8),
            field("name", STRING),
            field("msg", STRING),
            field("file", STRING),
            field("function", STRING),
            field("line", UINT32),
        ],
    };
    &INFO
}

/// `rcl_interfaces/msg/ParameterValue`.
pub fn parameter_value() -> &'static TypeInfo {
    static INFO: TypeInfo = TypeInfo {
        name: "rcl_interfaces/msg/ParameterValue",
        msg_text: "uint8 type\nbool bool_value\nint64 integer_value\nfloat64 double_value\nstring string_value\nbyte[] byte_array_value\nbool[] bool_array_value\nint64[] integer_array_value\nfloat64[] double_array_value\nstring[] string_array_value\n",
        fields: &[
            field("type", UINT8),
            field("bool_value", BOOL),
            field("integer_value", INT64),
            field("double_value", DOUBLE),
            field("string_value", STRING),
            field("byte_array_value", BYTE_SEQ),
            field("bool_array_value", BOOL_SEQ),
            field("integer_array_value", INT64_SEQ),
            field("double_array_value", DOUBLE_SEQ),
            field("string_array_value", STRING_SEQ),
        ],
    };
    &INFO
}

/// `rcl_interfaces/msg/Parameter`.
pub fn parameter() -> &'static TypeInfo {
    static INFO: TypeInfo = TypeInfo {
        name: "rcl_interfaces/msg/Parameter",
        msg_text: "string name\nParameterValue value\n",
        fields: &[field("name", STRING), nested("value", NESTED, parameter_value)],
    };
    &INFO
}

/// `rcl_interfaces/msg/ParameterEvent` (`/parameter_events`).
pub fn parameter_event() -> &'static TypeInfo {
    static INFO: TypeInfo = TypeInfo {
        name: "rcl_interfaces/msg/ParameterEvent",
        msg_text: "builtin_interfaces/Time stamp\nstring node\nParameter[] new_parameters\nParameter[] changed_parameters\nParameter[] deleted_parameters\n",
        fields: &[
            nested("stamp", NESTED, time),
            field("node", STRING),
            nested("new_parameters", NESTED_SEQ, parameter),
            nested("changed_parameters", NESTED_SEQ, parameter),
            nested("deleted_parameters", NESTED_SEQ, parameter),
        ],
    };
    &INFO
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::type_hash;

    /// The hashes rosidl generates (`share/rcl_interfaces/msg/*.json` of ROS 2 Jazzy).
    #[test]
    fn hashes_are_rosidls() {
        assert_eq!(type_hash(log()), "RIHS01_e28ce254ca8abc06abf92773b74602cdbf116ed34fbaf294fb9f81da9f318eac");
        assert_eq!(type_hash(parameter_value()), "RIHS01_115fc089a387e23c7ecd3525c9189c379109119d6ab82e8dfbde0fdf6a7f9b68");
        assert_eq!(type_hash(parameter()), "RIHS01_ddfe6442cffc462317adb5c92536a7b6dd55858c5c3e1e328165a6b73c2831af");
        assert_eq!(type_hash(parameter_event()), "RIHS01_043e627780fcad87a22d225bc2a037361dba713fca6a6b9f4b869a5aa0393204");
    }
}
