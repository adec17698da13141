//! Errors of the bag reader and writer: each names the file and what to do.

use std::fmt;
use std::path::{Path, PathBuf};

#[derive(Debug)]
pub enum BagError {
    Io { path: PathBuf, action: &'static str, err: std::io::Error },
    /// The file is not an MCAP file at all (wrong magic, empty).
    NotMcap { path: PathBuf, reason: String },
    Write { path: PathBuf, err: String },
    /// The writer was already finished.
    Closed { path: PathBuf },
    TopicNotFound { topic: String, available: Vec<String> },
    TypeMismatch { topic: String, in_bag: String, requested: String },
    Invalid(String),
}

impl BagError {
    pub(crate) fn io(path: &Path, action: &'static str, err: std::io::Error) -> Self {
        BagError::Io { path: path.to_path_buf(), action, err }
    }
    pub(crate) fn write(path: &Path, err: impl fmt::Display) -> Self {
        BagError::Write { path: path.to_path_buf(), err: err.to_string() }
    }
}

impl fmt::Display for BagError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BagError::Io { path, action, err } => write!(f, "could not {action} {}: {err}", path.display()),
            BagError::NotMcap { path, reason } => write!(
                f,
                "{} is not an MCAP bag ({reason}); give a .mcap file written by naic or `ros2 bag record -s mcap`",
                path.display()
            ),
            BagError::Write { path, err } => write!(f, "writing {} failed: {err}", path.display()),
            BagError::Closed { path } => write!(f, "bag {} is already finished; open a new writer", path.display()),
            BagError::TopicNotFound { topic, available } => write!(
                f,
                "topic {topic} is not in the bag; it has: {}",
                if available.is_empty() { "no topics".to_string() } else { available.join(", ") }
            ),
            BagError::TypeMismatch { topic, in_bag, requested } => {
                write!(f, "topic {topic} carries {in_bag}, not {requested}")
            }
            BagError::Invalid(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for BagError {}

/// Why the records of one chunk were not handed out (the reader notes it as damage at
/// the chunk's offset and reads on): each variant names the field and the values that
/// disagree, and what happens to the chunk's messages.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ChunkError {
    #[error("chunk header is malformed ({problem}; corrupted bytes); its messages are skipped")]
    MalformedHeader { problem: String },
    #[error("chunk record is cut off; its messages are skipped")]
    CutOff,
    #[error("chunk header claims {header} uncompressed bytes but the chunk index says {index} (corrupted header); its messages are skipped")]
    SizeDisagrees { header: u64, index: u64 },
    #[error("chunk claims {claimed} uncompressed bytes (corrupted header); skipped")]
    TooLarge { claimed: u64 },
    #[error("chunk claims {claimed} uncompressed bytes from {compressed} compressed ones (corrupted header); skipped")]
    Implausible { claimed: u64, compressed: u64 },
    #[error("chunk CRC mismatch (stored {stored:08x}, computed {computed:08x}: corrupted bytes); its messages are skipped")]
    Crc { stored: u32, computed: u32 },
    #[error("unknown chunk compression {compression:?}; its messages are skipped")]
    UnknownCompression { compression: String },
    #[error("a record inside a chunk runs past the chunk's end; the rest of the chunk is skipped")]
    RunsPastEnd,
    #[error("chunk does not decompress ({problem}; corrupted bytes); its messages are skipped")]
    Decompress { problem: String },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunk_errors_name_the_field_the_values_and_the_consequence() {
        let m = ChunkError::SizeDisagrees { header: 4096, index: 512 }.to_string();
        assert!(m.contains("claims 4096 uncompressed bytes") && m.contains("chunk index says 512") && m.contains("skipped"), "{m}");
        let m = ChunkError::Crc { stored: 0xdead_beef, computed: 0x1234 }.to_string();
        assert!(m.contains("stored deadbeef, computed 00001234") && m.contains("messages are skipped"), "{m}");
        let m = ChunkError::UnknownCompression { compression: "brotli".into() }.to_string();
        assert!(m.contains("\"brotli\"") && m.contains("skipped"), "{m}");
        let m = ChunkError::Implausible { claimed: 1 << 31, compressed: 100 }.to_string();
        assert!(m.contains("2147483648 uncompressed bytes from 100 compressed"), "{m}");
    }
}
