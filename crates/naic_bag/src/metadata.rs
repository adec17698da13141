//! The rosbag2 `serialized_metadata` YAML (the body of `metadata.yaml`'s
//! `rosbag2_bagfile_information`), stored in the MCAP `rosbag2` metadata record.

use crate::writer::{TopicSpec, ROSBAG2_METADATA_VERSION};
use std::fmt::Write;

/// Quotes a YAML scalar when it is not a plain safe string.
fn scalar(s: &str) -> String {
    let plain = !s.is_empty()
        && s.chars().all(|c| c.is_ascii_alphanumeric() || "/_~.-".contains(c))
        && !s.starts_with(['-', '~', '.'])
        && !matches!(s, "null" | "true" | "false" | "yes" | "no" | "on" | "off");
    if plain {
        s.to_string()
    } else {
        format!("\"{}\"", s.replace('\\', "\\\\").replace('"', "\\\""))
    }
}

/// Builds the YAML. `topics` pairs each topic with its message count.
pub fn serialized_metadata(file_name: &str, start_ns: u64, duration_ns: u64, topics: &[(&TopicSpec, u64)]) -> String {
    let total: u64 = topics.iter().map(|(_, n)| n).sum();
    let mut y = String::new();
    let _ = writeln!(y, "version: {ROSBAG2_METADATA_VERSION}");
    y.push_str("storage_identifier: mcap\n");
    let _ = writeln!(y, "duration:\n  nanoseconds: {duration_ns}");
    let _ = writeln!(y, "starting_time:\n  nanoseconds_since_epoch: {start_ns}");
    let _ = writeln!(y, "message_count: {total}");
    if topics.is_empty() {
        y.push_str("topics_with_message_count: []\n");
    } else {
        y.push_str("topics_with_message_count:\n");
        for (t, n) in topics {
            let _ = writeln!(y, "  - topic_metadata:");
            let _ = writeln!(y, "      name: {}", scalar(&t.topic));
            let _ = writeln!(y, "      type: {}", scalar(&t.type_name));
            y.push_str("      serialization_format: cdr\n");
            if t.qos.is_empty() {
                y.push_str("      offered_qos_profiles: []\n");
            } else {
                y.push_str("      offered_qos_profiles:\n");
                for q in &t.qos {
                    y.push_str(&q.yaml_item("        "));
                }
            }
            let _ = writeln!(y, "      type_description_hash: {}", scalar(&t.type_hash));
            let _ = writeln!(y, "    message_count: {n}");
        }
    }
    y.push_str("compression_format: \"\"\ncompression_mode: \"\"\n");
    let _ = writeln!(y, "relative_file_paths:\n  - {}", scalar(file_name));
    let _ = writeln!(
        y,
        "files:\n  - path: {}\n    starting_time:\n      nanoseconds_since_epoch: {start_ns}\n    duration:\n      nanoseconds: {duration_ns}\n    message_count: {total}",
        scalar(file_name)
    );
    y.push_str("custom_data: ~\nros_distro: jazzy\n");
    y
}
