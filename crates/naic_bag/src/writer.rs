//! rosbag2-compatible MCAP writer (what `ros2 bag record -s mcap` on Jazzy produces).

use crate::error::BagError;
use crate::qos::Qos;
use naic_msgs::{schema_text, type_hash, RosMessage};
use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// rosbag2 metadata format version written into `serialized_metadata` (Jazzy).
pub const ROSBAG2_METADATA_VERSION: u32 = 9;

/// Handle of a topic added to a [`BagWriter`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TopicId(pub u16);

/// A topic's definition as stored in the bag.
#[derive(Debug, Clone, PartialEq)]
pub struct TopicSpec {
    pub topic: String,
    /// `pkg/msg/Type`.
    pub type_name: String,
    /// rosbag2 `ros2msg` schema text (the .msg plus its dependencies).
    pub schema: String,
    /// `RIHS01_…` (may be empty if unknown).
    pub type_hash: String,
    pub qos: Vec<Qos>,
}

impl TopicSpec {
    /// The spec of a topic carrying the message type `M`, offered with `qos`.
    pub fn of<M: RosMessage>(topic: &str, qos: Qos) -> Self {
        let info = M::type_info();
        Self {
            topic: topic.to_string(),
            type_name: info.name.to_string(),
            schema: schema_text(info),
            type_hash: type_hash(info),
            qos: vec![qos],
        }
    }
}

struct TopicState {
    spec: TopicSpec,
    count: u64,
    sequence: u32,
}

/// Writes a rosbag2-compatible MCAP file: profile `ros2`, `ros2msg` schemas, `cdr` channels
/// with `offered_qos_profiles` and `topic_type_hash` metadata, zstd chunks, message and chunk
/// indexes, and at `finish` the `rosbag2` metadata record. The current chunk is closed and
/// the file flushed at least every `flush_interval` (default 1 s of wall time), so a crash
/// loses at most about that much.
pub struct BagWriter {
    mcap: Option<mcap::Writer<BufWriter<File>>>,
    path: PathBuf,
    topics: Vec<TopicState>,
    ids: Vec<u16>,
    buf: Vec<u8>,
    last_flush: Instant,
    flush_interval: Duration,
    start: u64,
    end: u64,
    count: u64,
}

impl BagWriter {
    /// Creates (or truncates) `path`.
    pub fn create(path: impl AsRef<Path>) -> Result<Self, BagError> {
        let path = path.as_ref().to_path_buf();
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| BagError::io(dir, "create the directory", e))?;
        }
        let file = File::create(&path).map_err(|e| BagError::io(&path, "create", e))?;
        let options = mcap::WriteOptions::new()
            .profile("ros2")
            .library(format!("naic_bag {}", env!("CARGO_PKG_VERSION")))
            .compression(Some(mcap::Compression::Zstd))
            .compression_threads(0)
            .chunk_size(Some(1024 * 1024))
            .emit_message_indexes(true)
            .emit_chunk_indexes(true)
            .emit_statistics(true)
            .emit_summary_offsets(true);
        let mcap = options
            .create(BufWriter::with_capacity(1 << 16, file))
            .map_err(|e| BagError::write(&path, e))?;
        Ok(Self {
            mcap: Some(mcap),
            path,
            topics: Vec::new(),
            ids: Vec::new(),
            buf: Vec::with_capacity(1024),
            last_flush: Instant::now(),
            flush_interval: Duration::from_secs(1),
            start: u64::MAX,
            end: 0,
            count: 0,
        })
    }

    /// Changes how often the open chunk is closed and flushed to disk (default 1 s).
    pub fn set_flush_interval(&mut self, d: Duration) {
        self.flush_interval = d;
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    fn mcap(&mut self) -> Result<&mut mcap::Writer<BufWriter<File>>, BagError> {
        let path = self.path.clone();
        self.mcap.as_mut().ok_or(BagError::Closed { path })
    }

    /// Adds a topic carrying `M`.
    pub fn add_topic<M: RosMessage>(&mut self, topic: &str, qos: Qos) -> Result<TopicId, BagError> {
        self.add_topic_spec(TopicSpec::of::<M>(topic, qos))
    }

    /// Adds a topic from a full spec (used when copying or repairing bags).
    pub fn add_topic_spec(&mut self, spec: TopicSpec) -> Result<TopicId, BagError> {
        if let Some(i) = self.topics.iter().position(|t| t.spec.topic == spec.topic) {
            if self.topics[i].spec.type_name != spec.type_name {
                return Err(BagError::TypeMismatch {
                    topic: spec.topic,
                    in_bag: self.topics[i].spec.type_name.clone(),
                    requested: spec.type_name,
                });
            }
            return Ok(TopicId(i as u16));
        }
        let path = self.path.clone();
        let mut meta = BTreeMap::new();
        meta.insert("offered_qos_profiles".to_string(), crate::qos::qos_yaml_string(&spec.qos));
        meta.insert("topic_type_hash".to_string(), spec.type_hash.clone());
        let w = self.mcap()?;
        let schema_id = w
            .add_schema(&spec.type_name, "ros2msg", spec.schema.as_bytes())
            .map_err(|e| BagError::write(&path, e))?;
        let channel_id = w
            .add_channel(schema_id, &spec.topic, "cdr", &meta)
            .map_err(|e| BagError::write(&path, e))?;
        self.ids.push(channel_id);
        self.topics.push(TopicState { spec, count: 0, sequence: 0 });
        Ok(TopicId((self.topics.len() - 1) as u16))
    }

    /// Serializes and writes one message. `log_time` = receive time, `publish_time` = the
    /// source stamp, both in ns.
    pub fn write<M: RosMessage>(
        &mut self,
        topic: TopicId,
        msg: &M,
        log_time: u64,
        publish_time: u64,
    ) -> Result<(), BagError> {
        let mut buf = std::mem::take(&mut self.buf);
        naic_msgs::cdr::encode_into(msg, &mut buf);
        let r = self.write_cdr(topic, &buf, log_time, publish_time);
        self.buf = buf;
        r
    }

    /// Writes one already-serialized message (CDR with its encapsulation header).
    pub fn write_cdr(
        &mut self,
        topic: TopicId,
        data: &[u8],
        log_time: u64,
        publish_time: u64,
    ) -> Result<(), BagError> {
        let i = topic.0 as usize;
        if i >= self.topics.len() {
            return Err(BagError::Invalid(format!("topic id {i} was not added to this bag")));
        }
        let t = &mut self.topics[i];
        t.sequence = t.sequence.wrapping_add(1);
        t.count += 1;
        let header = mcap::records::MessageHeader {
            channel_id: self.ids[i],
            sequence: t.sequence,
            log_time,
            publish_time,
        };
        self.start = self.start.min(log_time);
        self.end = self.end.max(log_time);
        self.count += 1;
        let path = self.path.clone();
        self.mcap()?.write_to_known_channel(&header, data).map_err(|e| BagError::write(&path, e))?;
        self.flush_if_due()
    }

    /// Flushes if the flush interval has passed since the last flush. A recorder whose topics
    /// may go quiet calls this from its loop so the last messages reach the disk too.
    pub fn flush_if_due(&mut self) -> Result<(), BagError> {
        if self.last_flush.elapsed() >= self.flush_interval {
            self.flush()?;
        }
        Ok(())
    }

    /// Closes the open chunk and flushes it to the operating system.
    pub fn flush(&mut self) -> Result<(), BagError> {
        let path = self.path.clone();
        self.last_flush = Instant::now();
        self.mcap()?.flush().map_err(|e| BagError::write(&path, e))
    }

    /// Messages written so far.
    pub fn message_count(&self) -> u64 {
        self.count
    }

    /// Writes the `rosbag2` metadata record, the summary and the footer.
    pub fn finish(mut self) -> Result<(), BagError> {
        self.finish_inner()
    }

    fn finish_inner(&mut self) -> Result<(), BagError> {
        let Some(mut w) = self.mcap.take() else { return Ok(()) };
        let file_name = self.path.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let topics: Vec<(&TopicSpec, u64)> = self.topics.iter().map(|t| (&t.spec, t.count)).collect();
        let (start, end) = if self.count == 0 { (0, 0) } else { (self.start, self.end) };
        let yaml = crate::metadata::serialized_metadata(&file_name, start, end - start, &topics);
        let mut md = BTreeMap::new();
        md.insert("serialized_metadata".to_string(), yaml);
        md.insert("ROS_DISTRO".to_string(), "jazzy".to_string());
        w.write_metadata(&mcap::records::Metadata { name: "rosbag2".into(), metadata: md })
            .map_err(|e| BagError::write(&self.path, e))?;
        w.finish().map_err(|e| BagError::write(&self.path, e))?;
        use std::io::Write;
        let mut inner = w.into_inner();
        inner.flush().map_err(|e| BagError::io(&self.path, "flush", e))?;
        Ok(())
    }
}

impl Drop for BagWriter {
    fn drop(&mut self) {
        // Best effort: a writer dropped without `finish` still leaves a complete, indexed file.
        if let Err(e) = self.finish_inner() {
            eprintln!("naic_bag: could not finish {}: {e}", self.path.display());
        }
    }
}
