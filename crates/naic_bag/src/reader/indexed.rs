//! Intact files: the footer and summary section are checked, then read with the `mcap`
//! crate (`Summary::read` for schemas, channels, statistics and the chunk and metadata
//! indexes; `read::metadata` for the metadata records). The chunks are then read through
//! their index, without walking the data section.

use super::{Bag, ChannelDef, SchemaDef, Source, MAGIC};
use mcap::records::{op, Record};

/// What the summary gave.
pub(super) struct Summary {
    /// Where the data section ends (the summary starts).
    pub data_end: usize,
    pub summary: mcap::Summary,
}

impl Summary {
    /// Does the index cover the whole data section, so that the file can be read through it
    /// alone? (An MCAP writer may leave chunk or metadata indexes out, or write messages
    /// outside chunks; such a file is read by walking its records.)
    pub fn is_complete(&self) -> bool {
        let s = &self.summary;
        let Some(stats) = &s.stats else { return false };
        s.chunk_indexes.len() == stats.chunk_count as usize
            && s.metadata_indexes.len() == stats.metadata_count as usize
            && (stats.chunk_count > 0 || stats.message_count == 0)
            && s.chunk_indexes.iter().all(|c| {
                let (o, l) = (c.chunk_start_offset as usize, c.chunk_length as usize);
                o >= MAGIC.len() && l >= 9 && o.saturating_add(l) <= self.data_end
            })
    }
}

impl Bag {
    /// Reads the summary section if the footer and the summary are intact (CRC included).
    /// Otherwise notes why and returns None, with where the data section ends.
    pub(super) fn read_summary(&self) -> Result<Summary, usize> {
        let n = self.data.len();
        // Footer record: opcode + u64 len (20) + 20 bytes, then magic. Checked here (the
        // crate's `read::footer` checks neither the opcode nor the length) to name the damage.
        const FOOTER_LEN: usize = 1 + 8 + 20;
        if n < 8 + FOOTER_LEN + 8 || &self.data[n - 8..] != MAGIC {
            self.note(n, "no footer: the file was not closed (recording interrupted or file cut); scanning all records");
            return Err(n);
        }
        let fpos = n - 8 - FOOTER_LEN;
        let f = &self.data[fpos..n - 8];
        let le64 = |b: &[u8]| u64::from_le_bytes(b[..8].try_into().unwrap());
        if f[0] != op::FOOTER || le64(&f[1..]) != 20 {
            self.note(fpos, "footer record is damaged; scanning all records");
            return Err(n);
        }
        let summary_start = le64(&f[9..]) as usize;
        let summary_crc = u32::from_le_bytes(f[25..29].try_into().unwrap());
        if summary_start == 0 {
            self.note(fpos, "the file has no summary section; scanning all records");
            return Err(fpos);
        }
        if summary_start < 8 || summary_start > fpos {
            self.note(fpos, "footer points outside the file; scanning all records");
            return Err(n);
        }
        // CRC of the summary section through the footer's summary_offset_start field (the
        // crate's summary reader does not check it).
        if summary_crc != 0 && crc32fast::hash(&self.data[summary_start..fpos + 1 + 8 + 16]) != summary_crc {
            self.note(summary_start, "summary section CRC mismatch (corrupted bytes); scanning all records");
            return Err(summary_start);
        }
        match mcap::Summary::read(&self.data) {
            Ok(Some(summary)) if summary.stats.is_some() => Ok(Summary { data_end: summary_start, summary }),
            Ok(_) => {
                self.note(summary_start, "summary section has no statistics; scanning all records");
                Err(summary_start)
            }
            Err(e) => {
                self.note(summary_start, format!("summary section is damaged ({e}); scanning all records"));
                Err(summary_start)
            }
        }
    }

    /// Takes schemas, channels, message counts and time bounds from the summary.
    pub(super) fn use_summary(&mut self, s: &Summary) {
        let summary = &s.summary;
        for (&id, sc) in &summary.schemas {
            self.schemas.insert(
                id,
                SchemaDef { name: sc.name.clone(), encoding: sc.encoding.clone(), data: sc.data.to_vec() },
            );
        }
        for (&id, c) in &summary.channels {
            self.channels.insert(
                id,
                ChannelDef {
                    id,
                    topic: c.topic.clone(),
                    message_encoding: c.message_encoding.clone(),
                    schema_id: c.schema.as_ref().map(|s| s.id).unwrap_or(0),
                    metadata: c.metadata.clone(),
                },
            );
        }
        if let Some(st) = &summary.stats {
            self.counts = st.channel_message_counts.clone();
            self.time_bounds = Some((st.message_start_time, st.message_end_time));
        }
        self.summary_ok = true;
    }

    /// Takes the chunks and metadata records from a complete index.
    pub(super) fn use_index(&mut self, s: &Summary) {
        let summary = &s.summary;
        let mut chunks = summary.chunk_indexes.clone();
        chunks.sort_by_key(|c| c.chunk_start_offset);
        for c in chunks {
            let offset = c.chunk_start_offset as usize;
            self.sources.push(Source::Chunk {
                offset,
                record: offset..offset + c.chunk_length as usize,
                start: c.message_start_time,
                end: c.message_end_time,
                indexed_size: Some(c.uncompressed_size),
            });
        }
        for m in &summary.metadata_indexes {
            match mcap::read::metadata(&self.data, m) {
                Ok(md) => self.metadata.push((md.name, md.metadata)),
                Err(e) => self.note(m.offset as usize, format!("metadata record {:?} is unreadable ({e})", m.name)),
            }
        }
        // The header record (profile, library) opens the data section.
        let d = &self.data;
        let header = (d.len() >= 17 && d[8] == op::HEADER)
            .then(|| u64::from_le_bytes(d[9..17].try_into().unwrap()) as usize)
            .and_then(|len| d.get(17..17usize.checked_add(len)?))
            .map(|body| mcap::parse_record(op::HEADER, body));
        match header {
            Some(Ok(Record::Header(h))) => {
                self.profile = h.profile;
                self.library = h.library;
            }
            _ => self.note(8, "header record is missing or malformed (corrupted bytes); profile and library unknown"),
        }
    }
}
