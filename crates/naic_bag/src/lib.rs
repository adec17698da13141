//! Recording and reading naic experiments as MCAP bags that rosbag2 (Jazzy) tools open.
//!
//! - [`BagWriter`]: rosbag2-compatible MCAP (profile `ros2`, `ros2msg` schemas, `cdr`
//!   channels with `offered_qos_profiles` and `topic_type_hash`, zstd chunks, message and
//!   chunk indexes, the `rosbag2` metadata record), flushed about every second.
//! - [`Bag`]: fast typed reads by topic and time range, tolerant of truncated and
//!   corrupted files ([`Bag::damage`] lists what was found); [`repair`] writes a clean copy.

mod error;
pub mod metadata;
pub mod qos;
mod reader;
pub mod run;
pub mod sample;
mod writer;

pub use error::{BagError, ChunkError};
pub use qos::Qos;
pub use reader::{AnyMessage, AnyStamped, Bag, ChannelDef, Damage, MessageRef, SchemaDef, Stamped, TimeRange, TopicInfo, MAGIC};
pub use run::RunData;
pub use writer::{BagWriter, TopicId, TopicSpec, ROSBAG2_METADATA_VERSION};

use std::path::Path;

/// What [`repair`] did.
#[derive(Debug, Clone)]
pub struct RepairReport {
    pub messages: u64,
    pub topics: usize,
    pub damage: Vec<Damage>,
}

/// Reads `input` with damage recovery and writes every recovered message to `output` as a
/// clean, indexed, rosbag2-compatible bag (same topics, types, schemas, QoS and times).
pub fn repair(input: impl AsRef<Path>, output: impl AsRef<Path>) -> Result<RepairReport, BagError> {
    let (input, output) = (input.as_ref(), output.as_ref());
    if input.canonicalize().ok().is_some() && input.canonicalize().ok() == output.canonicalize().ok() {
        return Err(BagError::Invalid(format!(
            "repair would overwrite its input {}; give a different output file",
            input.display()
        )));
    }
    let bag = Bag::open(input)?;
    let mut w = BagWriter::create(output)?;
    let mut ids = std::collections::HashMap::new();
    for ch in bag.channels() {
        if let Some(spec) = bag.topic_spec(ch.id) {
            ids.insert(ch.id, w.add_topic_spec(spec)?);
        }
    }
    let mut err = None;
    let mut n = 0u64;
    bag.for_each_message(None, TimeRange::ALL, |m| {
        if err.is_some() {
            return;
        }
        if let Some(&id) = ids.get(&m.channel_id) {
            match w.write_cdr(id, m.data, m.log_time, m.publish_time) {
                Ok(()) => n += 1,
                Err(e) => err = Some(e),
            }
        }
    });
    if let Some(e) = err {
        return Err(e);
    }
    w.finish()?;
    Ok(RepairReport { messages: n, topics: ids.len(), damage: bag.damage() })
}
