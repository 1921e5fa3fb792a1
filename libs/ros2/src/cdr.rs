//! The CDR encoding of ROS 2 messages as rmw implementations write them: OMG XCDR version 1
//! (plain CDR), little-endian, behind the 4-byte encapsulation header `00 01 00 00`
//! (`CDR_LE`, options 0).
//!
//! Rules: every primitive is aligned to its own size (1, 2, 4 or 8 bytes), counted from the end
//! of the encapsulation header; a `string` is a `uint32` length that counts its terminating NUL,
//! then its bytes and the NUL; a sequence (`T[]`) is a `uint32` element count, then its
//! elements; a fixed array (`T[N]`) is its N elements alone; a nested message is its fields in
//! order, with no alignment of its own. Nothing pads the end.

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
}
