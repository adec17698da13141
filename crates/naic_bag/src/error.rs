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
