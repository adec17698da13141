//! Fast, damage-tolerant MCAP reading.
//!
//! The whole file is read into memory once. An intact file (footer, summary and its CRC,
//! statistics and chunk indexes all there) is read with the `mcap` crate through its
//! index ([`indexed`]); any other file is walked record by record by the hand-written
//! recovery in [`recover`], which finds every complete message it can. Either way each
//! chunk is decompressed and CRC-checked by the crate ([`chunk`]) before any of its
//! records is used, chunks outside the requested time range are skipped without
//! decompressing, and message payloads are handed out as borrowed slices. Each problem is
//! recorded as a [`Damage`] with its file offset.

mod chunk;
mod decode;
mod indexed;
mod recover;

pub use decode::{AnyMessage, AnyStamped};

use crate::error::BagError;
use crate::qos::Qos;
use crate::writer::TopicSpec;
use mcap::records::{op, Record};
use naic_msgs::RosMessage;
use std::collections::{BTreeMap, HashMap};
use std::ops::{Bound, Range, RangeBounds};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// MCAP magic bytes at the start and end of a file.
pub const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";

/// A problem found in the file, with where it is.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Damage {
    /// Byte offset in the file.
    pub offset: u64,
    pub message: String,
}

impl std::fmt::Display for Damage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "at byte {}: {}", self.offset, self.message)
    }
}

/// A schema record.
#[derive(Debug, Clone)]
pub struct SchemaDef {
    pub name: String,
    pub encoding: String,
    pub data: Vec<u8>,
}

/// A channel record (one topic).
#[derive(Debug, Clone)]
pub struct ChannelDef {
    pub id: u16,
    pub topic: String,
    pub message_encoding: String,
    pub schema_id: u16,
    pub metadata: BTreeMap<String, String>,
}

/// One topic of the bag, for `info`.
#[derive(Debug, Clone)]
pub struct TopicInfo {
    pub channel_id: u16,
    pub topic: String,
    pub type_name: String,
    pub count: u64,
    pub type_hash: String,
}

/// A message borrowed from the bag (its data is a slice of the decompressed chunk).
#[derive(Debug, Clone, Copy)]
pub struct MessageRef<'a> {
    pub channel_id: u16,
    pub topic: &'a str,
    pub sequence: u32,
    /// Receive time [ns].
    pub log_time: u64,
    /// Source stamp [ns].
    pub publish_time: u64,
    /// CDR with its 4-byte encapsulation header.
    pub data: &'a [u8],
}

/// A decoded message with its bag times.
#[derive(Debug, Clone, PartialEq)]
pub struct Stamped<M> {
    pub log_time: u64,
    pub publish_time: u64,
    pub sequence: u32,
    pub msg: M,
}

/// Where messages are.
#[derive(Debug, Clone)]
enum Source {
    /// A complete chunk record (`record`: its bytes in the file, opcode and length
    /// included) with its log-time bounds and, from the chunk index, its uncompressed size.
    Chunk { offset: usize, record: Range<usize>, start: u64, end: u64, indexed_size: Option<u64> },
    /// Records decompressed from a truncated or unfinished chunk (index into `recovered`).
    Recovered(usize),
    /// A message record outside any chunk (body range).
    Loose(Range<usize>),
}

/// An MCAP bag held in memory, ready for fast reads.
pub struct Bag {
    path: PathBuf,
    data: Vec<u8>,
    profile: String,
    library: String,
    schemas: HashMap<u16, SchemaDef>,
    channels: BTreeMap<u16, ChannelDef>,
    sources: Vec<Source>,
    recovered: Vec<Vec<u8>>,
    metadata: Vec<(String, BTreeMap<String, String>)>,
    counts: BTreeMap<u16, u64>,
    time_bounds: Option<(u64, u64)>,
    summary_ok: bool,
    damage: Mutex<Vec<Damage>>,
}

/// An inclusive log-time range in ns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TimeRange {
    pub start: u64,
    pub end: u64,
}

impl TimeRange {
    pub const ALL: TimeRange = TimeRange { start: 0, end: u64::MAX };

    pub fn from_bounds(r: impl RangeBounds<u64>) -> Self {
        let start = match r.start_bound() {
            Bound::Included(&s) => s,
            Bound::Excluded(&s) => s.saturating_add(1),
            Bound::Unbounded => 0,
        };
        let end = match r.end_bound() {
            Bound::Included(&e) => e,
            Bound::Excluded(&e) => e.saturating_sub(1),
            Bound::Unbounded => u64::MAX,
        };
        Self { start, end }
    }

    #[inline(always)]
    pub fn contains(&self, t: u64) -> bool {
        t >= self.start && t <= self.end
    }
}

impl Bag {
    /// Reads and indexes `path`. Damage is tolerated and reported by [`Bag::damage`]; only a
    /// file that is unreadable or not MCAP at all is an error.
    pub fn open(path: impl AsRef<Path>) -> Result<Bag, BagError> {
        let path = path.as_ref();
        let data = std::fs::read(path).map_err(|e| BagError::io(path, "read", e))?;
        Bag::from_bytes(path, data)
    }

    /// Indexes an in-memory MCAP file (`path` is only used in messages).
    pub fn from_bytes(path: impl AsRef<Path>, data: Vec<u8>) -> Result<Bag, BagError> {
        let path = path.as_ref().to_path_buf();
        if data.len() < MAGIC.len() {
            return Err(BagError::NotMcap { path, reason: format!("the file has only {} bytes", data.len()) });
        }
        if &data[..8] != MAGIC {
            return Err(BagError::NotMcap { path, reason: "it does not start with the MCAP magic bytes".into() });
        }
        let mut bag = Bag {
            path,
            data,
            profile: String::new(),
            library: String::new(),
            schemas: HashMap::new(),
            channels: BTreeMap::new(),
            sources: Vec::new(),
            recovered: Vec::new(),
            metadata: Vec::new(),
            counts: BTreeMap::new(),
            time_bounds: None,
            summary_ok: false,
            damage: Mutex::new(Vec::new()),
        };
        match bag.read_summary() {
            Ok(s) => {
                bag.use_summary(&s);
                if s.is_complete() {
                    bag.use_index(&s);
                } else {
                    // Intact but not fully indexed (chunk or metadata indexes left out, or
                    // messages outside chunks): the data section is walked for them.
                    bag.scan_data(s.data_end);
                }
            }
            Err(data_end) => {
                bag.scan_data(data_end);
                bag.count_by_scanning();
            }
        }
        Ok(bag)
    }

    fn note(&self, offset: usize, message: impl Into<String>) {
        let d = Damage { offset: offset as u64, message: message.into() };
        let mut v = self.damage.lock().unwrap_or_else(|e| e.into_inner());
        if !v.contains(&d) {
            v.push(d);
        }
    }

    /// Calls `f(opcode, body)` for each record of source `s` (after decompression and CRC
    /// check). Records of a damaged chunk are not visited; the damage is noted.
    fn with_records(&self, s: usize, range: TimeRange, f: &mut dyn FnMut(u8, &[u8])) {
        match &self.sources[s] {
            Source::Loose(r) => f(op::MESSAGE, &self.data[r.clone()]),
            Source::Recovered(i) => self.recovered_records(*i, f),
            Source::Chunk { offset, record, start, end, indexed_size } => {
                if *end < range.start || *start > range.end {
                    return;
                }
                if let Err(e) = chunk::for_each_record(&self.data[record.clone()], *indexed_size, f) {
                    self.note(*offset, e.to_string());
                }
            }
        }
    }

    /// Visits every message of the given channels (all when `channels` is None) whose log time
    /// is in `range`, in file order. `f` gets the message borrowed from the bag.
    pub fn for_each_message(&self, channels: Option<&[u16]>, range: TimeRange, mut f: impl FnMut(MessageRef<'_>)) {
        let mut want = vec![channels.is_none(); 65536];
        if let Some(chs) = channels {
            for &c in chs {
                want[c as usize] = true;
            }
        }
        let topics: HashMap<u16, &str> = self.channels.values().map(|c| (c.id, c.topic.as_str())).collect();
        for s in 0..self.sources.len() {
            self.with_records(s, range, &mut |opc, body| {
                if let Some((h, data)) = message(opc, body) {
                    if want[h.channel_id as usize] && range.contains(h.log_time) {
                        if let Some(topic) = topics.get(&h.channel_id) {
                            f(MessageRef {
                                channel_id: h.channel_id,
                                topic,
                                sequence: h.sequence,
                                log_time: h.log_time,
                                publish_time: h.publish_time,
                                data,
                            });
                        }
                    }
                }
            });
        }
    }

    /// The channel of `topic`, checking it carries `M`.
    pub fn channel_for<M: RosMessage>(&self, topic: &str) -> Result<u16, BagError> {
        let ch = self.channel_by_topic(topic)?;
        let ty = self.type_name(ch);
        if ty != M::type_name() {
            return Err(BagError::TypeMismatch { topic: topic.into(), in_bag: ty.into(), requested: M::type_name().into() });
        }
        Ok(ch)
    }

    /// The channel id of `topic`.
    pub fn channel_by_topic(&self, topic: &str) -> Result<u16, BagError> {
        self.channels.values().find(|c| c.topic == topic).map(|c| c.id).ok_or_else(|| BagError::TopicNotFound {
            topic: topic.into(),
            available: self.channels.values().map(|c| c.topic.clone()).collect(),
        })
    }

    /// Decoded messages of `topic` with log time in `range` (ns), e.g.
    /// `bag.messages::<JointState>("/joint_states", ..)?`. Messages that fail to decode are
    /// skipped and reported in [`Bag::damage`].
    pub fn messages<M: RosMessage>(&self, topic: &str, range: impl RangeBounds<u64>) -> Result<Vec<Stamped<M>>, BagError> {
        let ch = self.channel_for::<M>(topic)?;
        let mut out = Vec::with_capacity(self.capacity_hint(self.counts.get(&ch).copied().unwrap_or(0)));
        let mut bad = 0usize;
        let mut first_err = None;
        self.for_each_message(Some(&[ch]), TimeRange::from_bounds(range), |m| match M::from_cdr(m.data) {
            Ok(msg) => out.push(Stamped { log_time: m.log_time, publish_time: m.publish_time, sequence: m.sequence, msg }),
            Err(e) => {
                bad += 1;
                first_err.get_or_insert(e);
            }
        });
        if let Some(e) = first_err {
            self.note(0, format!("{bad} message(s) on {topic} do not decode as {} (first: {e}); skipped", M::type_name()));
        }
        Ok(out)
    }

    /// A preallocation size from a (possibly corrupted) count: never more messages than the
    /// file could hold (each record takes at least 31 bytes).
    fn capacity_hint(&self, count: u64) -> usize {
        count.min(self.data.len() as u64 / 31) as usize
    }

    /// Type name of a channel (from its schema; empty if unknown).
    pub fn type_name(&self, channel: u16) -> &str {
        self.channels
            .get(&channel)
            .and_then(|c| self.schemas.get(&c.schema_id))
            .map(|s| s.name.as_str())
            .unwrap_or("")
    }

    /// Topics with their type and message count, sorted by topic name.
    pub fn topics(&self) -> Vec<TopicInfo> {
        let mut v: Vec<TopicInfo> = self
            .channels
            .values()
            .map(|c| TopicInfo {
                channel_id: c.id,
                topic: c.topic.clone(),
                type_name: self.type_name(c.id).to_string(),
                count: self.counts.get(&c.id).copied().unwrap_or(0),
                type_hash: c.metadata.get("topic_type_hash").cloned().unwrap_or_default(),
            })
            .collect();
        v.sort_by(|a, b| a.topic.cmp(&b.topic));
        v
    }

    /// The definition of a topic, suitable for writing it into another bag.
    pub fn topic_spec(&self, channel: u16) -> Option<TopicSpec> {
        let c = self.channels.get(&channel)?;
        let s = self.schemas.get(&c.schema_id);
        let qos = c.metadata.get("offered_qos_profiles").map(|y| Qos::from_yaml_lines(y)).unwrap_or_default();
        Some(TopicSpec {
            topic: c.topic.clone(),
            type_name: s.map(|s| s.name.clone()).unwrap_or_default(),
            schema: s.map(|s| String::from_utf8_lossy(&s.data).into_owned()).unwrap_or_default(),
            type_hash: c.metadata.get("topic_type_hash").cloned().unwrap_or_default(),
            qos,
        })
    }

    pub fn channels(&self) -> impl Iterator<Item = &ChannelDef> {
        self.channels.values()
    }

    pub fn schema(&self, id: u16) -> Option<&SchemaDef> {
        self.schemas.get(&id)
    }

    /// Total messages (from the summary, or counted when it was missing).
    pub fn message_count(&self) -> u64 {
        self.counts.values().sum()
    }

    /// First and last log time [ns].
    pub fn time_bounds(&self) -> Option<(u64, u64)> {
        self.time_bounds
    }

    /// Was the summary (index) intact?
    pub fn is_indexed(&self) -> bool {
        self.summary_ok
    }

    pub fn profile(&self) -> &str {
        &self.profile
    }

    pub fn library(&self) -> &str {
        &self.library
    }

    pub fn metadata(&self) -> &[(String, BTreeMap<String, String>)] {
        &self.metadata
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    pub fn file_size(&self) -> usize {
        self.data.len()
    }

    /// Number of chunks (including recovered partial ones).
    pub fn chunk_count(&self) -> usize {
        self.sources.iter().filter(|s| !matches!(s, Source::Loose(_))).count()
    }

    /// Problems found so far (opening finds structural ones; reading adds chunk-level ones).
    pub fn damage(&self) -> Vec<Damage> {
        self.damage.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }
}

/// The header and payload of a message record (None for other records and malformed ones).
#[inline(always)]
fn message(opcode: u8, body: &[u8]) -> Option<(mcap::records::MessageHeader, &[u8])> {
    if opcode != op::MESSAGE {
        return None;
    }
    match mcap::parse_record(opcode, body) {
        Ok(Record::Message { header, data: std::borrow::Cow::Borrowed(data) }) => Some((header, data)),
        _ => None,
    }
}
