//! Type descriptions (REP-2011): the rosbag2 schema text and the RIHS01 type hash.

use sha2::{Digest, Sha256};
use std::collections::BTreeSet;
use std::fmt::Write;

/// Static description of one message type.
pub struct TypeInfo {
    /// Full name `pkg/msg/Type`.
    pub name: &'static str,
    /// The `.msg` definition (fields and constants).
    pub msg_text: &'static str,
    /// Fields in `.msg` order (constants are not fields).
    pub fields: &'static [FieldInfo],
}

/// One field of a message, as in `type_description_interfaces/msg/Field`.
pub struct FieldInfo {
    pub name: &'static str,
    /// `type_description_interfaces/msg/FieldType` id (e.g. 11 = double, 155 = double[]).
    pub type_id: u8,
    /// The nested message type for nested fields.
    pub nested: Option<fn() -> &'static TypeInfo>,
}

/// Maps a Rust field type to its `FieldType` id (and nested type, if any).
pub trait FieldType {
    const TYPE_ID: u8;
    const NESTED: Option<fn() -> &'static TypeInfo> = None;
}

macro_rules! field_type {
    ($($t:ty => $id:expr),* $(,)?) => {$(
        impl FieldType for $t { const TYPE_ID: u8 = $id; }
    )*};
}

// Ids from type_description_interfaces/msg/FieldType.msg; unbounded sequences are id + 144.
field_type!(
    i8 => 2, u8 => 3, i16 => 4, u16 => 5, i32 => 6, u32 => 7, i64 => 8, u64 => 9,
    f32 => 10, f64 => 11, bool => 15, String => 17,
    Vec<i8> => 146, Vec<u8> => 147, Vec<i16> => 148, Vec<u16> => 149, Vec<i32> => 150,
    Vec<u32> => 151, Vec<i64> => 152, Vec<u64> => 153, Vec<f32> => 154, Vec<f64> => 155,
    Vec<String> => 161,
);

impl TypeInfo {
    /// `pkg/Type` as used after `MSG:` in a concatenated schema.
    pub fn short_name(&self) -> String {
        self.name.replacen("/msg/", "/", 1)
    }

    /// Direct nested dependencies, deduplicated, in byte order of their `pkg/Type` names.
    fn direct_dependencies(&self) -> Vec<&'static TypeInfo> {
        let mut deps: Vec<&'static TypeInfo> = Vec::new();
        for f in self.fields {
            if let Some(nested) = f.nested {
                let t = nested();
                if !deps.iter().any(|d| d.name == t.name) {
                    deps.push(t);
                }
            }
        }
        deps.sort_by_key(|t| t.short_name());
        deps
    }

    /// All transitive dependencies (not including self), sorted by full name.
    pub fn all_dependencies(&self) -> Vec<&'static TypeInfo> {
        let mut seen = BTreeSet::new();
        let mut out = Vec::new();
        let mut stack = self.direct_dependencies();
        while let Some(t) = stack.pop() {
            if seen.insert(t.name) {
                out.push(t);
                stack.extend(t.direct_dependencies());
            }
        }
        out.sort_by_key(|t| t.name);
        out
    }
}

/// The rosbag2 MCAP schema data (`ros2msg` encoding): the `.msg` text, then each
/// dependency once, depth-first with children in byte-sorted order, each after a line of
/// 80 `=` and `MSG: pkg/Type` (what `rosbag2_cpp::LocalMessageDefinitionSource` produces).
pub fn schema_text(info: &TypeInfo) -> String {
    fn walk(t: &TypeInfo, seen: &mut BTreeSet<&'static str>, out: &mut String) {
        for dep in t.direct_dependencies() {
            if seen.insert(dep.name) {
                out.push('\n');
                out.push_str(&"=".repeat(80));
                out.push('\n');
                let _ = writeln!(out, "MSG: {}", dep.short_name());
                out.push_str(dep.msg_text);
                walk(dep, seen, out);
            }
        }
    }
    let mut out = String::from(info.msg_text);
    let mut seen = BTreeSet::new();
    walk(info, &mut seen, &mut out);
    out
}

fn individual_json(t: &TypeInfo, out: &mut String) {
    let _ = write!(out, "{{\"type_name\": \"{}\", \"fields\": [", t.name);
    for (i, f) in t.fields.iter().enumerate() {
        if i > 0 {
            out.push_str(", ");
        }
        let nested = f.nested.map(|n| n().name).unwrap_or("");
        let _ = write!(
            out,
            "{{\"name\": \"{}\", \"type\": {{\"type_id\": {}, \"capacity\": 0, \"string_capacity\": 0, \"nested_type_name\": \"{}\"}}}}",
            f.name, f.type_id, nested
        );
    }
    out.push_str("]}");
}

/// The hashable JSON form of the full type description (REP-2011; what
/// `rosidl_generator_type_description.calculate_type_hash` feeds to SHA-256:
/// default values removed, `json.dumps` with `(', ', ': ')` separators, references sorted
/// by type name). None of our types has bounded fields or default values.
pub fn type_description_json(info: &TypeInfo) -> String {
    let mut out = String::from("{\"type_description\": ");
    individual_json(info, &mut out);
    out.push_str(", \"referenced_type_descriptions\": [");
    for (i, t) in info.all_dependencies().iter().enumerate() {
        if i > 0 {
            out.push_str(", ");
        }
        individual_json(t, &mut out);
    }
    out.push_str("]}");
    out
}

/// The REP-2011 type hash `RIHS01_<sha256 hex>`.
pub fn type_hash(info: &TypeInfo) -> String {
    let digest = Sha256::digest(type_description_json(info).as_bytes());
    let mut s = String::from("RIHS01_");
    for b in digest {
        let _ = write!(s, "{b:02x}");
    }
    s
}
