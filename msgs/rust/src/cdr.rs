//! CDR (XCDR1, little-endian) as used by ROS 2 (`rmw_fastrtps`, rclpy's
//! `serialize_message`) and stored by rosbag2, through the `cdr-encoding` crate: the
//! serde codec ros2-client (RustDDS) puts on the wire, so the wire and the bags share one
//! codec. This module adds what a bag needs around it: the 4-byte encapsulation header
//! `00 01 00 00` (CDR_LE; alignment restarts after it) and errors that say where the
//! message broke.
//!
//! Layout facts (checked byte for byte against rclpy in `tests/python/test_msgs_cdr.py`):
//! primitives are aligned to their own size (max 8); a string is a `u32` length that
//! counts the trailing NUL, the bytes, then NUL (an empty string is `01 00 00 00 00`); a
//! sequence is a `u32` element count followed by the elements, each aligned, so an empty
//! sequence has no padding after its count.
//!
//! Behaviour of the crate on malformed input, kept as it is: a string whose last byte is
//! not NUL is accepted (the crate logs a warning; ros2-client accepts it on the wire too),
//! and a sequence count larger than the data fails with "unexpected end of input" after
//! reading what there is (serde preallocates nothing from the count, so a corrupt count
//! cannot trigger a huge allocation).

use byteorder::LittleEndian;
use serde::{de::DeserializeOwned, Serialize};
use std::fmt;

/// CDR little-endian encapsulation header (representation id CDR_LE, options 0).
pub const ENCAPSULATION_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// Why a CDR buffer could not be decoded.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CdrError {
    /// The buffer ended before the message did (`offset`: bytes read, header included).
    Truncated { offset: usize, len: usize },
    /// The 4-byte encapsulation header is not CDR little-endian.
    Encapsulation([u8; 4]),
    /// A value that is not valid for its type (a bool byte other than 0 or 1, a string
    /// that is not UTF-8, ...), as `cdr-encoding` reports it.
    Invalid { offset: usize, reason: String },
}

impl fmt::Display for CdrError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CdrError::Truncated { offset, len } => {
                write!(f, "CDR data truncated: the message has {len} byte(s) and ended inside a field after byte {offset}")
            }
            CdrError::Encapsulation(h) => write!(
                f,
                "CDR encapsulation header {:02x} {:02x} {:02x} {:02x} is not CDR little-endian (00 01 00 00); \
                 only XCDR1 little-endian messages are supported",
                h[0], h[1], h[2], h[3]
            ),
            CdrError::Invalid { offset, reason } => write!(f, "CDR data invalid near byte {offset}: {reason}"),
        }
    }
}

impl std::error::Error for CdrError {}

/// A value that can be written as CDR (every serde `Serialize` type, fields in order).
pub trait CdrEncode: Serialize {}
impl<T: Serialize + ?Sized> CdrEncode for T {}

/// A value that can be read from CDR (every serde `DeserializeOwned` type).
pub trait CdrDecode: DeserializeOwned {}
impl<T: DeserializeOwned> CdrDecode for T {}

/// Serializes a message into `buf` (cleared first; its allocation is reused), with its
/// encapsulation header.
pub fn encode_into<M: CdrEncode>(msg: &M, buf: &mut Vec<u8>) {
    buf.clear();
    buf.extend_from_slice(&ENCAPSULATION_LE);
    // Writing into a Vec cannot fail, and every naic message type has only sequences of
    // known length: an error here is a bug in a message definition.
    cdr_encoding::to_writer::<M, LittleEndian, _>(&mut *buf, msg)
        .expect("CDR serialization of a ROS message into memory cannot fail");
}

/// Serializes a message into a new vector, with its encapsulation header.
pub fn encode<M: CdrEncode>(msg: &M) -> Vec<u8> {
    let mut buf = Vec::with_capacity(64);
    encode_into(msg, &mut buf);
    buf
}

/// Deserializes a complete serialized message (encapsulation header included). Bytes
/// after the last field (DDS pads a sample to a multiple of 4) are ignored.
pub fn decode<M: CdrDecode>(data: &[u8]) -> Result<M, CdrError> {
    if data.len() < 4 {
        return Err(CdrError::Truncated { offset: 0, len: data.len() });
    }
    let h = [data[0], data[1], data[2], data[3]];
    if h[0] != 0 || h[1] != 1 {
        return Err(CdrError::Encapsulation(h));
    }
    let mut de = cdr_encoding::CdrDeserializer::<LittleEndian>::new(&data[4..]);
    M::deserialize(&mut de).map_err(|e| {
        let offset = 4 + de.bytes_consumed();
        match e {
            cdr_encoding::Error::Eof => CdrError::Truncated { offset, len: data.len() },
            e => CdrError::Invalid { offset, reason: e.to_string() },
        }
    })
}
