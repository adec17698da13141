//! Damaged files: the part of the reader that stays hand-written.
//!
//! The `mcap` crate reads intact files (and every complete chunk, here too), but it stops
//! at the first damaged record: it cannot skip garbage to the next chunk, nor decompress
//! the complete records of a chunk that was cut off or was still being written when the
//! recorder died (its length field is a placeholder or runs past the end of the file).
//! Recovering those is what this module does. The data section is walked record by
//! record by their length fields: a record whose length runs past the end is treated as
//! truncated, a chunk that was still being written is decompressed as far as its bytes
//! go, garbage is skipped by searching for the next plausible chunk, and every complete
//! message found is kept. Each problem is noted as a [`super::Damage`] with its offset.

use super::{Bag, ChannelDef, SchemaDef, Source, TimeRange};
use mcap::records::{op, ChunkHeader, Record};
use std::collections::BTreeMap;

fn le_u64(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[at..at + 8].try_into().unwrap())
}

/// The header of a chunk record body, if it is well formed: its compressed data fills the
/// rest of the record and its compression is one naic reads.
fn chunk_header(body: &[u8]) -> Option<ChunkHeader> {
    match mcap::parse_record(op::CHUNK, body) {
        Ok(Record::Chunk { header, data }) => {
            // fixed fields (40 bytes) + compression name + data
            let exact = 40 + header.compression.len() + data.len() == body.len();
            (exact && matches!(header.compression.as_str(), "" | "zstd" | "lz4")).then_some(header)
        }
        _ => None,
    }
}

fn schema(body: &[u8]) -> Option<(u16, SchemaDef)> {
    match mcap::parse_record(op::SCHEMA, body) {
        Ok(Record::Schema { header, data }) => {
            Some((header.id, SchemaDef { name: header.name, encoding: header.encoding, data: data.into_owned() }))
        }
        _ => None,
    }
}

fn channel(body: &[u8]) -> Option<ChannelDef> {
    match mcap::parse_record(op::CHANNEL, body) {
        Ok(Record::Channel(c)) => Some(ChannelDef {
            id: c.id,
            topic: c.topic,
            message_encoding: c.message_encoding,
            schema_id: c.schema_id,
            metadata: c.metadata,
        }),
        _ => None,
    }
}

/// Decompresses `compressed` as far as it goes (for truncated chunks): returns the bytes
/// that could be decoded. (The crate's decompressors report an error for a cut stream
/// instead of the bytes decoded before the cut.)
fn decompress_partial(compression: &str, compressed: &[u8]) -> Vec<u8> {
    use std::io::Read;
    let mut out = Vec::new();
    let mut buf = [0u8; 64 * 1024];
    let mut drain = |d: &mut dyn Read| loop {
        match d.read(&mut buf) {
            Ok(0) | Err(_) => break,
            Ok(n) => out.extend_from_slice(&buf[..n]),
        }
    };
    match compression {
        "" => out.extend_from_slice(compressed),
        "zstd" => {
            if let Ok(mut d) = zstd::stream::read::Decoder::with_buffer(compressed) {
                drain(&mut d);
            }
        }
        "lz4" => {
            if let Ok(mut d) = lz4::Decoder::new(compressed) {
                drain(&mut d);
            }
        }
        _ => {}
    }
    out
}

impl Bag {
    /// Is `pos` the start of a plausible chunk record?
    fn plausible_chunk(&self, pos: usize, end: usize) -> bool {
        if end - pos < 9 || self.data[pos] != op::CHUNK {
            return false;
        }
        let len = le_u64(&self.data, pos + 1);
        if len == u64::MAX {
            // an unfinished chunk: its compression name must still be readable
            return matches!(self.partial_chunk_compression(pos, end).as_deref(), Some("zstd" | "lz4" | ""));
        }
        len <= (end - pos - 9) as u64 && chunk_header(&self.data[pos + 9..pos + 9 + len as usize]).is_some()
    }

    /// The compression name of a chunk whose record may be cut anywhere after it.
    fn partial_chunk_compression(&self, pos: usize, end: usize) -> Option<String> {
        let b = &self.data[pos + 9..end];
        // start, end, uncompressed_size (u64 each), uncompressed_crc (u32), then the name
        let n = u32::from_le_bytes(b.get(28..32)?.try_into().ok()?) as usize;
        String::from_utf8(b.get(32..32usize.checked_add(n)?)?.to_vec()).ok()
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
            if self.data[p] == op::DATA_END && end - p >= 13 && le_u64(&self.data, p + 1) == 4 {
                return p;
            }
            p += 1;
        }
        end
    }

    /// Decompresses what there is of a truncated/unfinished chunk and keeps its complete records.
    fn recover_partial_chunk(&mut self, pos: usize, end: usize) {
        let Some(compression) = self.partial_chunk_compression(pos, end) else {
            self.note(pos, "chunk header cut off; nothing to recover from it");
            return;
        };
        // fixed fields, name, then the records' length (a placeholder or beyond the end)
        let data_start = (pos + 9 + 32 + compression.len() + 8).min(end);
        let mut out = decompress_partial(&compression, &self.data[data_start..end]);
        // Keep only whole records.
        let mut p = 0;
        while out.len() - p >= 9 {
            let len = le_u64(&out, p + 1);
            if len > (out.len() - p - 9) as u64 {
                break;
            }
            p += 9 + len as usize;
        }
        out.truncate(p);
        if !out.is_empty() {
            self.recovered.push(out);
            self.sources.push(Source::Recovered(self.recovered.len() - 1));
        }
    }

    /// Walks the data section `8..end` record by record, collecting chunks, loose messages,
    /// the header, metadata and (when the summary was not usable) schemas and channels.
    pub(super) fn scan_data(&mut self, end: usize) {
        let mut pos = 8;
        while pos < end {
            let rem = end - pos;
            if rem < 9 {
                self.note(pos, format!("file ends {rem} byte(s) into a record header (truncated)"));
                break;
            }
            let opc = self.data[pos];
            let len = le_u64(&self.data, pos + 1);
            if opc == op::CHUNK && len == u64::MAX {
                self.note(pos, "chunk was still being written when the file ended (unfinished recording); recovering its complete messages");
                self.recover_partial_chunk(pos, end);
                pos = self.resync(pos + 1, end);
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
            let b = &self.data[body.clone()];
            let mut bad = false;
            match opc {
                op::HEADER => match mcap::parse_record(opc, b) {
                    Ok(Record::Header(h)) => {
                        self.profile = h.profile;
                        self.library = h.library;
                    }
                    _ => bad = true,
                },
                op::FOOTER => break,
                op::SCHEMA if !self.summary_ok => match schema(b) {
                    Some((id, s)) => {
                        self.schemas.insert(id, s);
                    }
                    None => bad = true,
                },
                op::CHANNEL if !self.summary_ok => match channel(b) {
                    Some(ch) => {
                        self.channels.insert(ch.id, ch);
                    }
                    None => bad = true,
                },
                op::MESSAGE => match mcap::parse_record(opc, b) {
                    Ok(Record::Message { .. }) => self.sources.push(Source::Loose(body.clone())),
                    _ => bad = true,
                },
                op::CHUNK => match chunk_header(b) {
                    Some(h) => self.sources.push(Source::Chunk {
                        offset: pos,
                        record: pos..body.end,
                        start: h.message_start_time,
                        end: h.message_end_time,
                        indexed_size: None,
                    }),
                    None => bad = true,
                },
                op::METADATA => match mcap::parse_record(opc, b) {
                    Ok(Record::Metadata(m)) => self.metadata.push((m.name, m.metadata)),
                    _ => bad = true,
                },
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
    pub(super) fn count_by_scanning(&mut self) {
        let mut schemas = Vec::new();
        let mut channels = Vec::new();
        let mut counts: BTreeMap<u16, u64> = BTreeMap::new();
        let mut bounds: Option<(u64, u64)> = None;
        for s in 0..self.sources.len() {
            self.with_records(s, TimeRange::ALL, &mut |opc, body| match opc {
                op::SCHEMA => schemas.extend(schema(body)),
                op::CHANNEL => channels.extend(channel(body)),
                op::MESSAGE => {
                    if let Ok(Record::Message { header: h, .. }) = mcap::parse_record(opc, body) {
                        *counts.entry(h.channel_id).or_default() += 1;
                        let t = h.log_time;
                        bounds = Some(bounds.map_or((t, t), |(a, b)| (a.min(t), b.max(t))));
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

    /// The records of a recovered partial chunk, walked by their lengths (they were cut to
    /// whole records when recovered).
    pub(super) fn recovered_records(&self, i: usize, f: &mut dyn FnMut(u8, &[u8])) {
        let records = &self.recovered[i];
        let mut p = 0;
        while records.len() - p >= 9 {
            let len = le_u64(records, p + 1) as usize;
            f(records[p], &records[p + 9..p + 9 + len]);
            p += 9 + len;
        }
    }
}
