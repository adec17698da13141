//! The records of one complete chunk, through the `mcap` crate's sans-io reader:
//! decompression (zstd, lz4), the CRC checked over the whole chunk before any record is
//! handed out (so a corrupted chunk yields nothing rather than wrong values), and record
//! lengths bounded by what the chunk can hold.

use mcap::records::{op, Record};
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
use mcap::McapError;

use crate::ChunkError;

/// The largest chunk we agree to decompress (guards against corrupt size fields).
const MAX_CHUNK: u64 = 1 << 32;

/// Calls `f(opcode, body)` for every record of the chunk record `record` (opcode, length
/// and body, as in the file). `indexed_size` is the uncompressed size the chunk index
/// gives, when there is one. An error says why the chunk (or its rest) was skipped.
pub(super) fn for_each_record(
    record: &[u8],
    indexed_size: Option<u64>,
    f: &mut dyn FnMut(u8, &[u8]),
) -> Result<(), ChunkError> {
    let header = match record.get(9..).map(|body| mcap::parse_record(op::CHUNK, body)) {
        Some(Ok(Record::Chunk { header, .. })) => header,
        Some(Err(e)) => return Err(ChunkError::MalformedHeader { problem: e.to_string() }),
        _ => return Err(ChunkError::CutOff),
    };
    let n = header.uncompressed_size;
    if let Some(index) = indexed_size.filter(|&x| x != n) {
        return Err(ChunkError::SizeDisagrees { header: n, index });
    }
    if n > MAX_CHUNK {
        return Err(ChunkError::TooLarge { claimed: n });
    }
    // Without an index to confirm it, a size far beyond what the compressed bytes could
    // plausibly hold is taken as a corrupted field rather than allocated.
    if indexed_size.is_none() && !header.compression.is_empty() && n > (64 << 20) && n > header.compressed_size.saturating_mul(100) {
        return Err(ChunkError::Implausible { claimed: n, compressed: header.compressed_size });
    }
    let limit = (n as usize).max(record.len());
    let mut r = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_skip_start_magic(true)
            .with_skip_end_magic(true)
            .with_prevalidate_chunk_crcs(true)
            .with_record_length_limit(limit),
    );
    r.insert(record.len()).copy_from_slice(record);
    r.notify_read(record.len());
    while let Some(event) = r.next_event() {
        match event {
            Ok(LinearReadEvent::Record { opcode, data }) => f(opcode, data),
            // The whole record was given: asking for more means the chunk is done.
            Ok(LinearReadEvent::ReadRequest(_)) => r.notify_read(0),
            Err(e) => return Err(describe(e)),
        }
    }
    Ok(())
}

fn describe(e: McapError) -> ChunkError {
    match e {
        McapError::BadChunkCrc { saved, calculated } => ChunkError::Crc { stored: saved, computed: calculated },
        McapError::UnsupportedCompression(compression) => ChunkError::UnknownCompression { compression },
        McapError::UnexpectedEof | McapError::UnexpectedEoc => ChunkError::RunsPastEnd,
        e => ChunkError::Decompress { problem: e.to_string() },
    }
}
