//! Fast, damage-tolerant MCAP reading.
//!
//! The whole file is read into memory once. Records are walked by their length fields
//! (chunks outside the requested time range are skipped without decompressing), chunk
//! CRCs are checked, and message payloads are handed out as slices of the decompressed
//! chunk (zero-copy). When the summary is intact it supplies schemas, channels and counts;
//! when it is missing or broken (a recording that crashed, a cut or corrupted file) the
//! data section is scanned linearly: a record whose length runs past the end is treated as
//! truncated, a chunk that was still being written is decompressed as far as its bytes go,
//! garbage is skipped by searching for the next plausible chunk, and every complete message
//! found is returned. Each problem is recorded as a [`Damage`] with its file offset.

use crate::error::BagError;
use crate::qos::Qos;
use crate::writer::TopicSpec;
use naic_msgs::RosMessage;
use std::sync::Mutex;
use std::collections::{BTreeMap, HashMap};
use std::ops::{Bound, Range, RangeBounds};
use std::path::{Path, PathBuf};

/// MCAP magic bytes at the start and end of a file.
pub const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";

mod op {
    pub const HEADER: u8 = 0x01;
    pub const FOOTER: u8 = 0x02;
    pub const SCHEMA: u8 = 0x03;
    pub const CHANNEL: u8 = 0x04;
    pub const MESSAGE: u8 = 0x05;
    pub const CHUNK: u8 = 0x06;
    pub const STATISTICS: u8 = 0x0B;
    pub const METADATA: u8 = 0x0C;
    pub const DATA_END: u8 = 0x0F;
}

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

#[derive(Debug, Clone)]
struct ChunkRef {
    offset: usize,
    start: u64,
    end: u64,
    uncompressed_size: u64,
    crc: u32,
    compression: String,
    data: Range<usize>,
}

#[derive(Debug, Clone)]
enum Source {
    Chunk(ChunkRef),
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

/// Little-endian cursor over a record body; every read is bounds-checked.
struct Cur<'a> {
    b: &'a [u8],
    p: usize,
}

impl<'a> Cur<'a> {
    fn new(b: &'a [u8]) -> Self {
        Self { b, p: 0 }
    }
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        if n > self.b.len() - self.p {
            return None;
        }
        let s = &self.b[self.p..self.p + n];
        self.p += n;
        Some(s)
    }
    fn u16(&mut self) -> Option<u16> {
        Some(u16::from_le_bytes(self.take(2)?.try_into().ok()?))
    }
    fn u32(&mut self) -> Option<u32> {
        Some(u32::from_le_bytes(self.take(4)?.try_into().ok()?))
    }
    fn u64(&mut self) -> Option<u64> {
        Some(u64::from_le_bytes(self.take(8)?.try_into().ok()?))
    }
    fn bytes32(&mut self) -> Option<&'a [u8]> {
        let n = self.u32()? as usize;
        self.take(n)
    }
    fn string(&mut self) -> Option<String> {
        String::from_utf8(self.bytes32()?.to_vec()).ok()
    }
    fn string_map(&mut self) -> Option<BTreeMap<String, String>> {
        let inner = self.bytes32()?;
        let mut c = Cur::new(inner);
        let mut m = BTreeMap::new();
        while c.p < inner.len() {
            let k = c.string()?;
            let v = c.string()?;
            m.insert(k, v);
        }
        Some(m)
    }
    fn rest(&mut self) -> &'a [u8] {
        let s = &self.b[self.p..];
        self.p = self.b.len();
        s
    }
}

fn parse_schema(body: &[u8]) -> Option<(u16, SchemaDef)> {
    let mut c = Cur::new(body);
    let id = c.u16()?;
    let name = c.string()?;
    let encoding = c.string()?;
    let data = c.bytes32()?.to_vec();
    Some((id, SchemaDef { name, encoding, data }))
}

fn parse_channel(body: &[u8]) -> Option<ChannelDef> {
    let mut c = Cur::new(body);
    let id = c.u16()?;
    let schema_id = c.u16()?;
    let topic = c.string()?;
    let message_encoding = c.string()?;
    let metadata = c.string_map()?;
    Some(ChannelDef { id, topic, message_encoding, schema_id, metadata })
}

/// Chunk header; `records` is the byte range of the (compressed) records relative to `body`.
fn parse_chunk(body: &[u8], offset: usize, body_start: usize) -> Option<ChunkRef> {
    let mut c = Cur::new(body);
    let start = c.u64()?;
    let end = c.u64()?;
    let uncompressed_size = c.u64()?;
    let crc = c.u32()?;
    let compression = c.string()?;
    let len = c.u64()?;
    if len != (body.len() - c.p) as u64 || !matches!(compression.as_str(), "" | "zstd" | "lz4") {
        return None;
    }
    let data = body_start + c.p..body_start + body.len();
    Some(ChunkRef { offset, start, end, uncompressed_size, crc, compression, data })
}

/// Message header fields and payload.
#[inline(always)]
fn parse_message(body: &[u8]) -> Option<(u16, u32, u64, u64, &[u8])> {
    if body.len() < 22 {
        return None;
    }
    let ch = u16::from_le_bytes([body[0], body[1]]);
    let seq = u32::from_le_bytes(body[2..6].try_into().ok()?);
    let log = u64::from_le_bytes(body[6..14].try_into().ok()?);
    let publ = u64::from_le_bytes(body[14..22].try_into().ok()?);
    Some((ch, seq, log, publ, &body[22..]))
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

/// Decompresses `compressed` as far as it goes (for truncated chunks): returns the bytes
/// that could be decoded.
fn decompress_partial(compression: &str, compressed: &[u8]) -> Vec<u8> {
    use std::io::Read;
    let mut out = Vec::new();
    let mut buf = [0u8; 64 * 1024];
    match compression {
        "" => out.extend_from_slice(compressed),
        "zstd" => {
            if let Ok(mut d) = zstd::stream::read::Decoder::with_buffer(compressed) {
                loop {
                    match d.read(&mut buf) {
                        Ok(0) | Err(_) => break,
                        Ok(n) => out.extend_from_slice(&buf[..n]),
                    }
                }
            }
        }
        "lz4" => {
            if let Ok(mut d) = lz4::Decoder::new(compressed) {
                loop {
                    match d.read(&mut buf) {
                        Ok(0) | Err(_) => break,
                        Ok(n) => out.extend_from_slice(&buf[..n]),
                    }
                }
            }
        }
        _ => {}
    }
    out
}

/// The largest chunk we agree to decompress (guards against corrupt size fields).
const MAX_CHUNK: u64 = 1 << 32;

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
        let data_end = bag.read_summary();
        bag.scan_data(data_end);
        if !bag.summary_ok {
            bag.count_by_scanning();
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

    /// Reads the summary section if the footer and every summary record are intact.
    /// Returns where the data section ends.
    fn read_summary(&mut self) -> usize {
        let n = self.data.len();
        // Footer record: opcode + u64 len (20) + 20 bytes, then magic.
        const FOOTER_LEN: usize = 1 + 8 + 20;
        if n < 8 + FOOTER_LEN + 8 || &self.data[n - 8..] != MAGIC {
            self.note(n, "no footer: the file was not closed (recording interrupted or file cut); scanning all records");
            return n;
        }
        let fpos = n - 8 - FOOTER_LEN;
        let mut c = Cur::new(&self.data[fpos..n - 8]);
        let ok = c.take(1) == Some(&[op::FOOTER][..]) && c.u64() == Some(20);
        let summary_start = c.u64().unwrap_or(0) as usize;
        if !ok {
            self.note(fpos, "footer record is damaged; scanning all records");
            return n;
        }
        if summary_start == 0 {
            self.note(fpos, "the file has no summary section; scanning all records");
            return fpos;
        }
        if summary_start < 8 || summary_start > fpos {
            self.note(fpos, "footer points outside the file; scanning all records");
            return n;
        }
        let _summary_offset_start = c.u64();
        let summary_crc = c.u32().unwrap_or(0);
        // CRC of the summary section through the footer's summary_offset_start field.
        if summary_crc != 0 && crc32fast::hash(&self.data[summary_start..fpos + 1 + 8 + 16]) != summary_crc {
            self.note(summary_start, "summary section CRC mismatch (corrupted bytes); scanning all records");
            return summary_start;
        }
        let mut schemas = HashMap::new();
        let mut channels = BTreeMap::new();
        let mut counts = BTreeMap::new();
        let mut bounds = None;
        let mut pos = summary_start;
        let mut good = true;
        while pos < fpos {
            if fpos - pos < 9 {
                good = false;
                break;
            }
            let opc = self.data[pos];
            let len = u64::from_le_bytes(self.data[pos + 1..pos + 9].try_into().unwrap());
            if len > (fpos - pos - 9) as u64 {
                good = false;
                break;
            }
            let body = &self.data[pos + 9..pos + 9 + len as usize];
            match opc {
                op::SCHEMA => match parse_schema(body) {
                    Some((id, s)) => {
                        schemas.insert(id, s);
                    }
                    None => good = false,
                },
                op::CHANNEL => match parse_channel(body) {
                    Some(ch) => {
                        channels.insert(ch.id, ch);
                    }
                    None => good = false,
                },
                op::STATISTICS => {
                    let mut c = Cur::new(body);
                    let parsed = (|| {
                        let _count = c.u64()?;
                        c.take(2 + 4 + 4 + 4 + 4)?;
                        let s = c.u64()?;
                        let e = c.u64()?;
                        let m = c.bytes32()?;
                        let mut cm = Cur::new(m);
                        let mut out = BTreeMap::new();
                        while cm.p < m.len() {
                            out.insert(cm.u16()?, cm.u64()?);
                        }
                        Some((s, e, out))
                    })();
                    match parsed {
                        Some((s, e, out)) => {
                            bounds = Some((s, e));
                            counts = out;
                        }
                        None => good = false,
                    }
                }
                0x01..=0x0F | 0x80..=0xFF => {}
                _ => good = false,
            }
            if !good {
                break;
            }
            pos += 9 + len as usize;
        }
        if !good || bounds.is_none() {
            self.note(summary_start, "summary section is damaged or has no statistics; scanning all records");
            return summary_start;
        }
        self.schemas = schemas;
        self.channels = channels;
        self.counts = counts;
        self.time_bounds = bounds;
        self.summary_ok = true;
        summary_start
    }

    /// Is `pos` the start of a plausible chunk record?
    fn plausible_chunk(&self, pos: usize, end: usize) -> bool {
        if end - pos < 9 || self.data[pos] != op::CHUNK {
            return false;
        }
        let len = u64::from_le_bytes(self.data[pos + 1..pos + 9].try_into().unwrap());
        if len == u64::MAX {
            // an unfinished chunk: its compression name must still be readable
            let mut c = Cur::new(&self.data[pos + 9..end]);
            return c.take(28).is_some() && matches!(c.string().as_deref(), Some("zstd" | "lz4" | ""));
        }
        len <= (end - pos - 9) as u64 && parse_chunk(&self.data[pos + 9..pos + 9 + len as usize], pos, pos + 9).is_some()
    }

    /// Next offset ≥ `from` where a plausible chunk or the data-end record starts.
    fn resync(&self, from: usize, end: usize) -> usize {
        let mut p = from;
        while p < end {
            match self.data[p..end].iter().position(|&b| b == op::CHUNK || b == op::DATA_END) {
                None => return end,
                Some(i) => p += i,
            }
            if self.plausible_chunk(p, end) {
                return p;
            }
            if self.data[p] == op::DATA_END
                && end - p >= 13
                && u64::from_le_bytes(self.data[p + 1..p + 9].try_into().unwrap()) == 4
            {
                return p;
            }
            p += 1;
        }
        end
    }

    /// Decompresses what there is of a truncated/unfinished chunk and keeps its complete records.
    fn recover_partial_chunk(&mut self, pos: usize, end: usize) {
        let mut c = Cur::new(&self.data[pos + 9..end]);
        let compression = c.take(28).and_then(|_| c.string());
        let Some(compression) = compression else {
            self.note(pos, "chunk header cut off; nothing to recover from it");
            return;
        };
        c.take(8); // records length (placeholder or beyond the end)
        let data = c.rest();
        let out = decompress_partial(&compression, data);
        // Keep only whole records.
        let mut p = 0;
        while out.len() - p >= 9 {
            let len = u64::from_le_bytes(out[p + 1..p + 9].try_into().unwrap());
            if len > (out.len() - p - 9) as u64 {
                break;
            }
            p += 9 + len as usize;
        }
        let mut out = out;
        out.truncate(p);
        if !out.is_empty() {
            self.recovered.push(out);
            self.sources.push(Source::Recovered(self.recovered.len() - 1));
        }
    }

    fn scan_data(&mut self, end: usize) {
        let mut pos = 8;
        while pos < end {
            let rem = end - pos;
            if rem < 9 {
                self.note(pos, format!("file ends {rem} byte(s) into a record header (truncated)"));
                break;
            }
            let opc = self.data[pos];
            let len = u64::from_le_bytes(self.data[pos + 1..pos + 9].try_into().unwrap());
            if opc == op::CHUNK && len == u64::MAX {
                self.note(pos, "chunk was still being written when the file ended (unfinished recording); recovering its complete messages");
                self.recover_partial_chunk(pos, end);
                let next = self.resync(pos + 1, end);
                pos = next;
                continue;
            }
            if !matches!(opc, 0x01..=0x0F | 0x80..=0xFF) {
                self.note(pos, format!("invalid record opcode 0x{opc:02x} (corrupted bytes); skipping to the next chunk"));
                pos = self.resync(pos + 1, end);
                continue;
            }
            if len > (rem - 9) as u64 {
                if opc == op::CHUNK {
                    self.note(pos, format!(
                        "chunk record needs {len} bytes but the file ends after {} (truncated or corrupted length); recovering its complete messages",
                        rem - 9
                    ));
                    self.recover_partial_chunk(pos, end);
                } else {
                    self.note(pos, format!("record 0x{opc:02x} runs past the end of the file (truncated or corrupted length)"));
                }
                pos = self.resync(pos + 1, end);
                continue;
            }
            let body = pos + 9..pos + 9 + len as usize;
            let mut bad = false;
            match opc {
                op::HEADER => {
                    let mut c = Cur::new(&self.data[body.clone()]);
                    match (c.string(), c.string()) {
                        (Some(p), Some(l)) => {
                            self.profile = p;
                            self.library = l;
                        }
                        _ => bad = true,
                    }
                }
                op::FOOTER => break,
                op::SCHEMA if !self.summary_ok => match parse_schema(&self.data[body.clone()]) {
                    Some((id, s)) => {
                        self.schemas.insert(id, s);
                    }
                    None => bad = true,
                },
                op::CHANNEL if !self.summary_ok => match parse_channel(&self.data[body.clone()]) {
                    Some(ch) => {
                        self.channels.insert(ch.id, ch);
                    }
                    None => bad = true,
                },
                op::MESSAGE => {
                    if parse_message(&self.data[body.clone()]).is_some() {
                        self.sources.push(Source::Loose(body.clone()));
                    } else {
                        bad = true
                    }
                }
                op::CHUNK => match parse_chunk(&self.data[body.clone()], pos, body.start) {
                    Some(c) => self.sources.push(Source::Chunk(c)),
                    None => bad = true,
                },
                op::METADATA => {
                    let mut c = Cur::new(&self.data[body.clone()]);
                    match (c.string(), c.string_map()) {
                        (Some(n), Some(m)) => self.metadata.push((n, m)),
                        _ => bad = true,
                    }
                }
                _ => {}
            }
            if bad {
                self.note(pos, format!("record 0x{opc:02x} is malformed (corrupted bytes); skipping to the next chunk"));
                pos = self.resync(pos + 1, end);
                continue;
            }
            pos = body.end;
        }
    }

    /// Without a usable summary: one pass over every chunk to collect schemas, channels
    /// defined inside chunks, message counts and time bounds.
    fn count_by_scanning(&mut self) {
        let mut schemas = Vec::new();
        let mut channels = Vec::new();
        let mut counts: BTreeMap<u16, u64> = BTreeMap::new();
        let mut bounds: Option<(u64, u64)> = None;
        let mut buf = Vec::new();
        for s in 0..self.sources.len() {
            self.with_records(s, &mut buf, TimeRange::ALL, &mut |opc, body| match opc {
                op::SCHEMA => schemas.extend(parse_schema(body)),
                op::CHANNEL => channels.extend(parse_channel(body)),
                op::MESSAGE => {
                    if let Some((ch, _, log, _, _)) = parse_message(body) {
                        *counts.entry(ch).or_default() += 1;
                        bounds = Some(match bounds {
                            None => (log, log),
                            Some((a, b)) => (a.min(log), b.max(log)),
                        });
                    }
                }
                _ => {}
            });
        }
        for (id, s) in schemas {
            self.schemas.entry(id).or_insert(s);
        }
        for c in channels {
            self.channels.entry(c.id).or_insert(c);
        }
        // messages on channels whose definition was lost cannot be typed
        for (&ch, &n) in &counts {
            if !self.channels.contains_key(&ch) {
                self.note(0, format!("{n} message(s) on channel {ch} whose definition was lost; they are skipped"));
            }
        }
        self.counts = counts;
        self.time_bounds = bounds;
    }

    /// Calls `f(opcode, body)` for each record of source `s` (after decompression and CRC
    /// check). Records of a damaged chunk are not visited; the damage is noted.
    fn with_records(&self, s: usize, buf: &mut Vec<u8>, range: TimeRange, f: &mut dyn FnMut(u8, &[u8])) {
        let records: &[u8] = match &self.sources[s] {
            Source::Loose(r) => {
                f(op::MESSAGE, &self.data[r.clone()]);
                return;
            }
            Source::Recovered(i) => &self.recovered[*i],
            Source::Chunk(c) => {
                if c.end < range.start || c.start > range.end {
                    return;
                }
                match self.chunk_records(c, buf) {
                    Ok(r) => r,
                    Err(e) => {
                        self.note(c.offset, e);
                        return;
                    }
                }
            }
        };
        let mut p = 0;
        while records.len() - p >= 9 {
            let opc = records[p];
            let len = u64::from_le_bytes(records[p + 1..p + 9].try_into().unwrap());
            if len > (records.len() - p - 9) as u64 {
                let at = match &self.sources[s] {
                    Source::Chunk(c) => c.offset,
                    _ => 0,
                };
                self.note(at, "a record inside a chunk runs past the chunk's end; the rest of the chunk is skipped");
                return;
            }
            f(opc, &records[p + 9..p + 9 + len as usize]);
            p += 9 + len as usize;
        }
    }

    /// The uncompressed records of a chunk (borrowed when uncompressed).
    fn chunk_records<'a>(&'a self, c: &ChunkRef, buf: &'a mut Vec<u8>) -> Result<&'a [u8], String> {
        let raw = &self.data[c.data.clone()];
        let out: &[u8] = match c.compression.as_str() {
            "" => raw,
            "zstd" | "lz4" => {
                if c.uncompressed_size > MAX_CHUNK {
                    return Err(format!("chunk claims {} uncompressed bytes (corrupted header); skipped", c.uncompressed_size));
                }
                buf.clear();
                let n = c.uncompressed_size as usize;
                // A size far beyond what the compressed bytes could plausibly hold is decoded
                // with a streaming decoder capped at that size instead of being allocated up
                // front (a corrupted size field must not exhaust memory).
                let suspicious = n > (64 << 20) && n as u64 > raw.len() as u64 * 100;
                if c.compression == "zstd" && !suspicious {
                    buf.resize(n, 0);
                    match zstd::bulk::decompress_to_buffer(raw, &mut buf[..]) {
                        Ok(m) if m == n => {}
                        Ok(m) => return Err(format!("chunk decompressed to {m} bytes, header says {n} (corrupted); its messages are skipped")),
                        Err(e) => return Err(format!("chunk does not decompress ({e}; corrupted bytes); its messages are skipped")),
                    }
                } else if suspicious {
                    let out = decompress_partial(&c.compression, raw);
                    if out.len() != n {
                        return Err(format!(
                            "chunk header claims {n} uncompressed bytes but it holds {} (corrupted); its messages are skipped",
                            out.len()
                        ));
                    }
                    *buf = out;
                } else {
                    use std::io::Read;
                    let r = lz4::Decoder::new(raw).and_then(|mut d| {
                        buf.resize(n, 0);
                        d.read_exact(buf)
                    });
                    if let Err(e) = r {
                        return Err(format!("lz4 chunk does not decompress ({e}; corrupted bytes); its messages are skipped"));
                    }
                }
                &buf[..]
            }
            other => return Err(format!("unknown chunk compression {other:?}")),
        };
        if c.crc != 0 {
            let crc = crc32fast::hash(out);
            if crc != c.crc {
                return Err(format!(
                    "chunk CRC mismatch (stored {:08x}, computed {crc:08x}: corrupted bytes); its messages are skipped",
                    c.crc
                ));
            }
        }
        Ok(out)
    }

    /// Visits every message of the given channels (all when `channels` is None) whose log time
    /// is in `range`, in file order. `f` gets the message borrowed from the bag.
    pub fn for_each_message(
        &self,
        channels: Option<&[u16]>,
        range: TimeRange,
        mut f: impl FnMut(MessageRef<'_>),
    ) {
        let mut buf = Vec::new();
        let mut want = vec![channels.is_none(); 65536];
        if let Some(chs) = channels {
            for &c in chs {
                want[c as usize] = true;
            }
        }
        let topics: HashMap<u16, &str> = self.channels.values().map(|c| (c.id, c.topic.as_str())).collect();
        for s in 0..self.sources.len() {
            self.with_records(s, &mut buf, range, &mut |opc, body| {
                if opc != op::MESSAGE {
                    return;
                }
                if let Some((ch, sequence, log_time, publish_time, data)) = parse_message(body) {
                    if want[ch as usize] && range.contains(log_time) {
                        if let Some(topic) = topics.get(&ch) {
                            f(MessageRef { channel_id: ch, topic, sequence, log_time, publish_time, data });
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
        self.channels
            .values()
            .find(|c| c.topic == topic)
            .map(|c| c.id)
            .ok_or_else(|| BagError::TopicNotFound {
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

/// A message of any type naic knows, decoded.
#[derive(Debug, Clone, PartialEq)]
pub enum AnyMessage {
    JointState(naic_msgs::JointState),
    WrenchStamped(naic_msgs::WrenchStamped),
    Float64MultiArray(naic_msgs::Float64MultiArray),
    NaicParams(naic_msgs::NaicParams),
    Clock(naic_msgs::Clock),
}

#[derive(Clone, Copy)]
enum Kind {
    Js,
    Ws,
    Fa,
    Np,
    Ck,
    Unknown,
}

impl Kind {
    fn of(type_name: &str) -> Kind {
        use naic_msgs::*;
        match type_name {
            t if t == JointState::type_name() => Kind::Js,
            t if t == WrenchStamped::type_name() => Kind::Ws,
            t if t == Float64MultiArray::type_name() => Kind::Fa,
            t if t == NaicParams::type_name() => Kind::Np,
            t if t == Clock::type_name() => Kind::Ck,
            _ => Kind::Unknown,
        }
    }
    #[inline]
    fn decode(self, data: &[u8]) -> Option<Result<AnyMessage, naic_msgs::CdrError>> {
        use naic_msgs::*;
        Some(match self {
            Kind::Js => JointState::from_cdr(data).map(AnyMessage::JointState),
            Kind::Ws => WrenchStamped::from_cdr(data).map(AnyMessage::WrenchStamped),
            Kind::Fa => Float64MultiArray::from_cdr(data).map(AnyMessage::Float64MultiArray),
            Kind::Np => NaicParams::from_cdr(data).map(AnyMessage::NaicParams),
            Kind::Ck => Clock::from_cdr(data).map(AnyMessage::Clock),
            Kind::Unknown => return None,
        })
    }
}

/// A decoded message with its channel and bag times.
#[derive(Debug, Clone, PartialEq)]
pub struct AnyStamped {
    pub channel_id: u16,
    pub log_time: u64,
    pub publish_time: u64,
    pub sequence: u32,
    pub msg: AnyMessage,
}

impl Bag {
    /// Streams, in one pass over the file, every message of a known type (JointState,
    /// WrenchStamped, Float64MultiArray, NaicParams, Clock) with log time in `range`, decoded,
    /// in file order. Messages of other types are left out (read them raw with
    /// [`Bag::for_each_message`]); undecodable ones are skipped and reported in [`Bag::damage`].
    pub fn for_each_decoded(&self, range: impl RangeBounds<u64>, mut f: impl FnMut(AnyStamped)) {
        let range = TimeRange::from_bounds(range);
        let mut kinds = vec![Kind::Unknown; 65536];
        for c in self.channels.values() {
            kinds[c.id as usize] = Kind::of(self.type_name(c.id));
        }
        let mut bad = 0usize;
        let mut buf = Vec::new();
        for s in 0..self.sources.len() {
            self.with_records(s, &mut buf, range, &mut |opc, body| {
                if opc != op::MESSAGE {
                    return;
                }
                if let Some((ch, sequence, log_time, publish_time, data)) = parse_message(body) {
                    if !range.contains(log_time) {
                        return;
                    }
                    match kinds[ch as usize].decode(data) {
                        Some(Ok(msg)) => f(AnyStamped { channel_id: ch, log_time, publish_time, sequence, msg }),
                        Some(Err(_)) => bad += 1,
                        None => {}
                    }
                }
            });
        }
        if bad > 0 {
            self.note(0, format!("{bad} message(s) do not decode as their channel's type; skipped"));
        }
    }

    /// [`Bag::for_each_decoded`] collected into a vector.
    pub fn decode_all(&self, range: impl RangeBounds<u64>) -> Vec<AnyStamped> {
        let mut out = Vec::with_capacity(self.capacity_hint(self.message_count()));
        self.for_each_decoded(range, |m| out.push(m));
        out
    }
}
