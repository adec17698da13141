//! CDR (XCDR1, little-endian) encoding as used by ROS 2 (`rmw_fastrtps`, rclpy's
//! `serialize_message`) and stored by rosbag2.
//!
//! Layout facts this module implements (checked byte for byte against rclpy in
//! `tests/python/test_msgs_cdr.py`):
//! - a 4-byte encapsulation header `00 01 00 00` (CDR_LE), after which alignment restarts;
//! - primitives are aligned to their own size (max 8);
//! - a string is a `u32` length that counts the trailing NUL, the bytes, then NUL
//!   (so an empty string is `01 00 00 00 00`);
//! - a sequence is a `u32` element count followed by the elements; the alignment of the
//!   element type is applied only before the first element, so an empty sequence has no
//!   padding after its count.

use std::fmt;

/// CDR little-endian encapsulation header (representation id CDR_LE, options 0).
pub const ENCAPSULATION_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// Why a CDR buffer could not be decoded.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CdrError {
    /// The buffer ended before the message did.
    Truncated { needed: usize, offset: usize, len: usize },
    /// The 4-byte encapsulation header is not CDR little-endian.
    Encapsulation([u8; 4]),
    /// A string is not valid UTF-8 or misses its terminating NUL.
    BadString { offset: usize, reason: &'static str },
    /// A bool byte other than 0 or 1.
    BadBool { offset: usize, value: u8 },
}

impl fmt::Display for CdrError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CdrError::Truncated { needed, offset, len } => write!(
                f,
                "CDR data truncated: needed {needed} byte(s) at offset {offset} but the message has {len}"
            ),
            CdrError::Encapsulation(h) => write!(
                f,
                "CDR encapsulation header {:02x} {:02x} {:02x} {:02x} is not CDR little-endian (00 01 00 00); \
                 only XCDR1 little-endian messages are supported",
                h[0], h[1], h[2], h[3]
            ),
            CdrError::BadString { offset, reason } => write!(f, "CDR string at offset {offset}: {reason}"),
            CdrError::BadBool { offset, value } => {
                write!(f, "CDR bool at offset {offset} has value {value} (must be 0 or 1)")
            }
        }
    }
}

impl std::error::Error for CdrError {}

/// Appends CDR data to a byte vector (which it can reuse: no allocation once it is large enough).
pub struct CdrWriter<'a> {
    buf: &'a mut Vec<u8>,
    /// Index in `buf` where alignment counting starts (just after the encapsulation header).
    origin: usize,
}

impl<'a> CdrWriter<'a> {
    /// Clears `buf` and writes the encapsulation header.
    pub fn new(buf: &'a mut Vec<u8>) -> Self {
        buf.clear();
        buf.extend_from_slice(&ENCAPSULATION_LE);
        Self { buf, origin: 4 }
    }

    #[inline(always)]
    pub fn align(&mut self, n: usize) {
        let pos = self.buf.len() - self.origin;
        let pad = (n - pos % n) % n;
        for _ in 0..pad {
            self.buf.push(0);
        }
    }

    #[inline(always)]
    pub fn bytes(&mut self, b: &[u8]) {
        self.buf.extend_from_slice(b);
    }

    #[inline(always)]
    pub fn u32(&mut self, v: u32) {
        self.align(4);
        self.bytes(&v.to_le_bytes());
    }

    #[inline(always)]
    pub fn str(&mut self, s: &str) {
        self.u32(s.len() as u32 + 1);
        self.bytes(s.as_bytes());
        self.buf.push(0);
    }
}

/// Reads CDR data from a borrowed buffer without copying it.
pub struct CdrReader<'a> {
    buf: &'a [u8],
    pos: usize,
    origin: usize,
}

impl<'a> CdrReader<'a> {
    /// Checks the encapsulation header of a complete serialized message.
    pub fn new(buf: &'a [u8]) -> Result<Self, CdrError> {
        if buf.len() < 4 {
            return Err(CdrError::Truncated { needed: 4, offset: 0, len: buf.len() });
        }
        let h = [buf[0], buf[1], buf[2], buf[3]];
        if h[0] != 0 || h[1] != 1 {
            return Err(CdrError::Encapsulation(h));
        }
        Ok(Self { buf, pos: 4, origin: 4 })
    }

    /// Byte offset of the next read (from the start of the buffer, header included).
    pub fn position(&self) -> usize {
        self.pos
    }

    /// Bytes not yet read.
    pub fn remaining(&self) -> usize {
        self.buf.len() - self.pos
    }

    #[inline(always)]
    pub fn align(&mut self, n: usize) -> Result<(), CdrError> {
        let rel = self.pos - self.origin;
        let pad = (n - rel % n) % n;
        if self.pos + pad > self.buf.len() {
            return Err(self.truncated(pad));
        }
        self.pos += pad;
        Ok(())
    }

    fn truncated(&self, needed: usize) -> CdrError {
        CdrError::Truncated { needed, offset: self.pos, len: self.buf.len() }
    }

    #[inline(always)]
    pub fn take(&mut self, n: usize) -> Result<&'a [u8], CdrError> {
        if n > self.buf.len() - self.pos {
            return Err(self.truncated(n));
        }
        let s = &self.buf[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    #[inline(always)]
    fn array<const N: usize>(&mut self) -> Result<[u8; N], CdrError> {
        self.align(N)?;
        let s = self.take(N)?;
        let mut a = [0u8; N];
        a.copy_from_slice(s);
        Ok(a)
    }

    #[inline(always)]
    pub fn u32(&mut self) -> Result<u32, CdrError> {
        Ok(u32::from_le_bytes(self.array::<4>()?))
    }

    /// A sequence length, checked against the bytes left (each element takes at least
    /// `min_elem_size` bytes), so corrupt data cannot trigger a huge allocation.
    #[inline(always)]
    pub fn seq_len(&mut self, min_elem_size: usize) -> Result<usize, CdrError> {
        let n = self.u32()? as usize;
        if n.saturating_mul(min_elem_size) > self.remaining() {
            return Err(CdrError::Truncated {
                needed: n.saturating_mul(min_elem_size),
                offset: self.pos,
                len: self.buf.len(),
            });
        }
        Ok(n)
    }

    /// A string borrowed from the buffer (zero-copy).
    #[inline(always)]
    pub fn str(&mut self) -> Result<&'a str, CdrError> {
        let n = self.u32()? as usize;
        if n == 0 {
            // Not produced by ROS 2 (which always counts the NUL) but harmless.
            return Ok("");
        }
        let start = self.pos;
        let b = self.take(n)?;
        if b[n - 1] != 0 {
            return Err(CdrError::BadString { offset: start, reason: "missing terminating NUL" });
        }
        std::str::from_utf8(&b[..n - 1])
            .map_err(|_| CdrError::BadString { offset: start, reason: "not valid UTF-8" })
    }
}

/// A value that can be written as CDR.
pub trait CdrEncode {
    fn encode(&self, w: &mut CdrWriter<'_>);
}

/// A value that can be read from CDR.
pub trait CdrDecode: Sized {
    fn decode(r: &mut CdrReader<'_>) -> Result<Self, CdrError>;
}

macro_rules! cdr_primitive {
    ($($t:ty),*) => {$(
        impl CdrEncode for $t {
            #[inline(always)]
            fn encode(&self, w: &mut CdrWriter<'_>) {
                w.align(std::mem::size_of::<$t>());
                w.bytes(&self.to_le_bytes());
            }
        }
        impl CdrDecode for $t {
            #[inline(always)]
            fn decode(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
                Ok(<$t>::from_le_bytes(r.array::<{ std::mem::size_of::<$t>() }>()?))
            }
        }
        impl CdrEncode for Vec<$t> {
            fn encode(&self, w: &mut CdrWriter<'_>) {
                w.u32(self.len() as u32);
                if !self.is_empty() {
                    w.align(std::mem::size_of::<$t>());
                    for v in self {
                        w.bytes(&v.to_le_bytes());
                    }
                }
            }
        }
        impl CdrDecode for Vec<$t> {
            fn decode(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
                const S: usize = std::mem::size_of::<$t>();
                let n = r.seq_len(S)?;
                if n == 0 {
                    return Ok(Vec::new());
                }
                r.align(S)?;
                let bytes = r.take(n * S)?;
                Ok(bytes
                    .chunks_exact(S)
                    .map(|c| <$t>::from_le_bytes(c.try_into().unwrap()))
                    .collect())
            }
        }
    )*};
}

cdr_primitive!(i8, u8, i16, u16, i32, u32, i64, u64, f32, f64);

impl CdrEncode for bool {
    #[inline(always)]
    fn encode(&self, w: &mut CdrWriter<'_>) {
        w.bytes(&[*self as u8]);
    }
}

impl CdrDecode for bool {
    #[inline(always)]
    fn decode(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        let offset = r.position();
        match r.take(1)?[0] {
            0 => Ok(false),
            1 => Ok(true),
            value => Err(CdrError::BadBool { offset, value }),
        }
    }
}

impl CdrEncode for String {
    #[inline(always)]
    fn encode(&self, w: &mut CdrWriter<'_>) {
        w.str(self);
    }
}

impl CdrDecode for String {
    #[inline(always)]
    fn decode(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        r.str().map(str::to_owned)
    }
}

impl CdrEncode for Vec<String> {
    fn encode(&self, w: &mut CdrWriter<'_>) {
        w.u32(self.len() as u32);
        for s in self {
            w.str(s);
        }
    }
}

impl CdrDecode for Vec<String> {
    fn decode(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        let n = r.seq_len(4)?;
        let mut v = Vec::with_capacity(n);
        for _ in 0..n {
            v.push(r.str()?.to_owned());
        }
        Ok(v)
    }
}

/// Serializes a message into `buf` (cleared first; its allocation is reused).
pub fn encode_into<M: CdrEncode>(msg: &M, buf: &mut Vec<u8>) {
    let mut w = CdrWriter::new(buf);
    msg.encode(&mut w);
}

/// Serializes a message into a new vector, with its encapsulation header.
pub fn encode<M: CdrEncode>(msg: &M) -> Vec<u8> {
    let mut buf = Vec::with_capacity(64);
    encode_into(msg, &mut buf);
    buf
}

/// Deserializes a complete serialized message (encapsulation header included).
/// Up to 3 trailing padding bytes after the last field are accepted, as DDS
/// implementations may pad a sample to a multiple of 4.
pub fn decode<M: CdrDecode>(data: &[u8]) -> Result<M, CdrError> {
    let mut r = CdrReader::new(data)?;
    M::decode(&mut r)
}
