//! The CDR encoding of ROS 2 messages as rmw implementations write them: OMG XCDR version 1
//! (plain CDR), little-endian, behind the 4-byte encapsulation header `00 01 00 00`
//! (`CDR_LE`, options 0).
//!
//! Rules: every primitive is aligned to its own size (1, 2, 4 or 8 bytes), counted from the end
//! of the encapsulation header; a `string` is a `uint32` length that counts its terminating NUL,
//! then its bytes and the NUL; a sequence (`T[]`) is a `uint32` element count, then its
//! elements; a fixed array (`T[N]`) is its N elements alone; a nested message is its fields in
//! order, with no alignment of its own. Nothing pads the end.
//!
//! [`CdrReader`] reads the same layout back (and big-endian `CDR_BE`, header `00 00 00 00`),
//! bounds-checked: a short or malformed message is a [`CdrError`] naming the byte.

/// The encapsulation header: representation `CDR_LE` (0x0001), options 0.
pub const ENCAPSULATION_CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// Writes one message's CDR bytes, header first.
#[derive(Debug, Clone)]
pub struct CdrWriter {
    buf: Vec<u8>,
}

impl Default for CdrWriter {
    fn default() -> Self {
        Self::new()
    }
}

impl CdrWriter {
    /// A writer holding only the encapsulation header.
    pub fn new() -> Self {
        Self::with_capacity(64)
    }

    /// A writer with room for `bytes` bytes of message.
    pub fn with_capacity(bytes: usize) -> Self {
        let mut buf = Vec::with_capacity(bytes + 4);
        buf.extend_from_slice(&ENCAPSULATION_CDR_LE);
        Self { buf }
    }

    /// Pads with zeros to a multiple of `bytes`, counted after the encapsulation header.
    fn align(&mut self, bytes: usize) {
        let pos = self.buf.len() - ENCAPSULATION_CDR_LE.len();
        let pad = (bytes - pos % bytes) % bytes;
        self.buf.resize(self.buf.len() + pad, 0);
    }

    pub fn bool(&mut self, v: bool) {
        self.buf.push(u8::from(v));
    }

    pub fn u8(&mut self, v: u8) {
        self.buf.push(v);
    }

    pub fn u16(&mut self, v: u16) {
        self.align(2);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    pub fn u32(&mut self, v: u32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    pub fn i32(&mut self, v: i32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    pub fn u64(&mut self, v: u64) {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    pub fn f64(&mut self, v: f64) {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    /// A `string`: length with the NUL, bytes, NUL.
    ///
    /// # Panics
    ///
    /// If the string is 4 GiB or longer (CDR counts in 32 bits).
    pub fn string(&mut self, s: &str) {
        self.u32(u32::try_from(s.len() + 1).expect("a CDR string is shorter than 4 GiB"));
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
    }

    /// The element count of a sequence that follows.
    ///
    /// # Panics
    ///
    /// If `n` does not fit in 32 bits.
    pub fn sequence_len(&mut self, n: usize) {
        self.u32(u32::try_from(n).expect("a CDR sequence has fewer than 2^32 elements"));
    }

    /// A `uint8[]` sequence: count, then the bytes.
    pub fn bytes(&mut self, data: &[u8]) {
        self.sequence_len(data.len());
        self.buf.extend_from_slice(data);
    }

    /// A `float64[N]` fixed array (no count).
    pub fn f64_array(&mut self, values: &[f64]) {
        for &v in values {
            self.f64(v);
        }
    }

    /// A `float64[]` sequence.
    pub fn f64_sequence(&mut self, values: &[f64]) {
        self.sequence_len(values.len());
        self.f64_array(values);
    }

    /// The bytes written so far, header included.
    pub fn into_bytes(self) -> Vec<u8> {
        self.buf
    }
}

/// A value with a CDR encoding: a message's fields in order.
pub trait CdrEncode {
    fn encode(&self, w: &mut CdrWriter);
}

/// A top-level ROS 2 message: its type name (`pkg/msg/Type`) and its whole CDR payload.
pub trait RosMessage: CdrEncode {
    /// The ROS 2 type name, e.g. `sensor_msgs/msg/CompressedImage`.
    const TYPE_NAME: &'static str;

    /// The message's serialized bytes, encapsulation header first.
    fn to_cdr(&self) -> Vec<u8> {
        let mut w = CdrWriter::new();
        self.encode(&mut w);
        w.into_bytes()
    }
}

impl<T: CdrEncode> CdrEncode for [T] {
    /// A sequence: count, then the elements.
    fn encode(&self, w: &mut CdrWriter) {
        w.sequence_len(self.len());
        for v in self {
            v.encode(w);
        }
    }
}

/// Why a CDR message could not be read: the byte offset in the message (header included).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("CDR byte {offset}: {what}")]
pub struct CdrError {
    pub offset: usize,
    pub what: String,
}

/// Reads one message's CDR bytes, encapsulation header first.
#[derive(Debug, Clone)]
pub struct CdrReader<'a> {
    buf: &'a [u8],
    pos: usize,
    little: bool,
}

impl<'a> CdrReader<'a> {
    /// A reader after the encapsulation header (`CDR_LE` or `CDR_BE`, options ignored).
    pub fn new(buf: &'a [u8]) -> Result<Self, CdrError> {
        let little = match buf.get(..2) {
            Some([0x00, 0x01]) => true,
            Some([0x00, 0x00]) => false,
            Some(_) => {
                return Err(CdrError {
                    offset: 0,
                    what: "encapsulation is neither CDR_LE nor CDR_BE".into(),
                });
            }
            None => {
                return Err(CdrError {
                    offset: 0,
                    what: "no encapsulation header".into(),
                });
            }
        };
        if buf.len() < 4 {
            return Err(CdrError {
                offset: 0,
                what: "no encapsulation header".into(),
            });
        }
        Ok(Self {
            buf,
            pos: 4,
            little,
        })
    }

    /// Where the next read starts (header included).
    pub fn position(&self) -> usize {
        self.pos
    }

    fn take<const N: usize>(&mut self, align: usize) -> Result<[u8; N], CdrError> {
        let rel = self.pos - ENCAPSULATION_CDR_LE.len();
        let start = self.pos + (align - rel % align) % align;
        let bytes: [u8; N] = self
            .buf
            .get(start..start + N)
            .and_then(|s| s.try_into().ok())
            .ok_or_else(|| CdrError {
                offset: start,
                what: format!("the message ends inside a {N}-byte value"),
            })?;
        self.pos = start + N;
        Ok(if self.little {
            bytes
        } else {
            let mut b = bytes;
            b.reverse();
            b
        })
    }

    pub fn u8(&mut self) -> Result<u8, CdrError> {
        Ok(self.take::<1>(1)?[0])
    }

    pub fn bool(&mut self) -> Result<bool, CdrError> {
        Ok(self.u8()? != 0)
    }

    pub fn u32(&mut self) -> Result<u32, CdrError> {
        self.take::<4>(4).map(u32::from_le_bytes)
    }

    pub fn i32(&mut self) -> Result<i32, CdrError> {
        self.take::<4>(4).map(i32::from_le_bytes)
    }

    pub fn u64(&mut self) -> Result<u64, CdrError> {
        self.take::<8>(8).map(u64::from_le_bytes)
    }

    /// A `uint8[]` sequence (or a string's bytes with their NUL): count, then the bytes.
    pub fn bytes(&mut self) -> Result<&'a [u8], CdrError> {
        let at = self.pos;
        let n = self.u32()? as usize;
        let data = self
            .buf
            .get(self.pos..)
            .and_then(|b| b.get(..n))
            .ok_or_else(|| CdrError {
                offset: at,
                what: format!("a sequence of {n} bytes runs past the end of the message"),
            })?;
        self.pos += n;
        Ok(data)
    }

    /// A `string`: its length counts the terminating NUL.
    pub fn string(&mut self) -> Result<String, CdrError> {
        let at = self.pos;
        let bytes = self.bytes()?;
        let text = bytes.strip_suffix(&[0]).unwrap_or(bytes);
        String::from_utf8(text.to_vec()).map_err(|_| CdrError {
            offset: at,
            what: "a string is not UTF-8".into(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn primitives_align_to_their_size_after_the_header() {
        let mut w = CdrWriter::new();
        w.u8(0xAB); // offset 0
        w.u16(0x0102); // pad 1, offset 2
        w.bool(true); // offset 4
        w.u32(0x0A0B0C0D); // pad 3, offset 8
        w.u64(0x1122334455667788); // pad 4, offset 16
        w.u8(7); // offset 24
        w.f64(1.0); // pad 7, offset 32
        w.i32(-2); // offset 40
        #[rustfmt::skip]
        let want: Vec<u8> = vec![
            0x00, 0x01, 0x00, 0x00,                         // encapsulation: CDR_LE
            0xAB, 0x00, 0x02, 0x01,                         // u8, pad, u16 LE
            0x01, 0x00, 0x00, 0x00,                         // bool, pad ×3
            0x0D, 0x0C, 0x0B, 0x0A,                         // u32 LE
            0x00, 0x00, 0x00, 0x00,                         // pad to 16
            0x88, 0x77, 0x66, 0x55, 0x44, 0x33, 0x22, 0x11, // u64 LE
            0x07, 0, 0, 0, 0, 0, 0, 0,                      // u8, pad ×7
            0, 0, 0, 0, 0, 0, 0xF0, 0x3F,                   // f64 1.0
            0xFE, 0xFF, 0xFF, 0xFF,                         // i32 −2
        ];
        assert_eq!(w.into_bytes(), want);
    }

    #[test]
    fn strings_count_their_nul_and_sequences_their_elements() {
        let mut w = CdrWriter::new();
        w.string("ab"); // len 3 incl. NUL
        w.string(""); // len 1: just the NUL (aligned to 4 first)
        w.bytes(&[9, 8, 7]);
        w.f64_sequence(&[0.5]); // count at 20, pad to 24, value
        #[rustfmt::skip]
        let want: Vec<u8> = vec![
            0x00, 0x01, 0x00, 0x00,
            0x03, 0x00, 0x00, 0x00, b'a', b'b', 0x00,       // "ab"
            0x00,                                           // pad to 8
            0x01, 0x00, 0x00, 0x00, 0x00,                   // ""
            0x00, 0x00, 0x00,                               // pad to 16
            0x03, 0x00, 0x00, 0x00, 9, 8, 7,                // uint8[] {9, 8, 7}
            0x00,                                           // pad to 24 (offset 23 → 24)
            0x01, 0x00, 0x00, 0x00,                         // float64[] count 1
            0x00, 0x00, 0x00, 0x00,                         // pad to 32
            0, 0, 0, 0, 0, 0, 0xE0, 0x3F,                   // 0.5
        ];
        assert_eq!(w.into_bytes(), want);
    }

    #[test]
    fn the_reader_reads_what_the_writer_writes_and_names_a_short_message() {
        let mut w = CdrWriter::new();
        w.u8(7);
        w.i32(-5);
        w.string("evt3");
        w.bool(true);
        w.u64(1 << 40);
        w.bytes(&[1, 2, 3]);
        w.u32(9);
        let b = w.into_bytes();
        let mut r = CdrReader::new(&b).unwrap();
        assert_eq!(r.u8().unwrap(), 7);
        assert_eq!(r.i32().unwrap(), -5);
        assert_eq!(r.string().unwrap(), "evt3");
        assert!(r.bool().unwrap());
        assert_eq!(r.u64().unwrap(), 1 << 40);
        assert_eq!(r.bytes().unwrap(), &[1, 2, 3]);
        assert_eq!(r.u32().unwrap(), 9);
        assert_eq!(r.position(), b.len());
        let e = r.u32().unwrap_err();
        assert_eq!(e.offset, b.len(), "{e}");
        let mut cut = CdrReader::new(&b[..14]).unwrap();
        cut.u8().unwrap();
        cut.i32().unwrap();
        let e = cut.string().unwrap_err();
        assert!(e.to_string().contains("CDR byte 12"), "{e}");
        // Big-endian: the same values, bytes reversed.
        let be = [0, 0, 0, 0, 0, 0, 0, 5];
        assert_eq!(CdrReader::new(&be).unwrap().u32().unwrap(), 5);
        assert!(CdrReader::new(&[0x12, 0x34, 0, 0]).is_err());
    }
}
