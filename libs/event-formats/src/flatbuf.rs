//! The little of the FlatBuffers binary format AEDAT4 needs, bounds-checked: reading tables,
//! scalars, strings and vectors of structs from an untrusted buffer, and laying out the two
//! small tables Waggle writes.
//!
//! Layout (FlatBuffers' "internals" documentation): a buffer starts with a `uoffset` (`u32`,
//! forward, relative to where it is stored) to its root table, optionally followed by a
//! four-character file identifier. A table starts with an `soffset` (`i32`): its vtable is at
//! `table − soffset`. A vtable is `u16` vtable size, `u16` table size, then one `u16` per field:
//! the field's offset inside the table, 0 when absent (the field then has its default). Strings
//! and vectors are reached by a `uoffset` and start with a `u32` length (a string's bytes are
//! followed by a NUL). Everything is little-endian.
//!
//! Why not the `flatbuffers` crate: its table accessors are `unsafe` and trust the buffer, and
//! its safe, verified entry points need the code `flatc` generates. Every read here checks its
//! bounds and returns the buffer position that was bad, so a damaged file gives an error naming
//! its byte offset and never reads out of bounds.

/// A read outside the buffer or a malformed offset, at `pos` (relative to the buffer).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct FbError {
    pub pos: usize,
    pub what: &'static str,
}

fn bad(pos: usize, what: &'static str) -> FbError {
    FbError { pos, what }
}

fn take<const N: usize>(buf: &[u8], pos: usize) -> Result<[u8; N], FbError> {
    pos.checked_add(N)
        .and_then(|end| buf.get(pos..end))
        .and_then(|s| s.try_into().ok())
        .ok_or_else(|| bad(pos, "runs past the end of the buffer"))
}

pub(crate) fn u16_at(buf: &[u8], pos: usize) -> Result<u16, FbError> {
    take::<2>(buf, pos).map(u16::from_le_bytes)
}

pub(crate) fn u32_at(buf: &[u8], pos: usize) -> Result<u32, FbError> {
    take::<4>(buf, pos).map(u32::from_le_bytes)
}

pub(crate) fn i32_at(buf: &[u8], pos: usize) -> Result<i32, FbError> {
    take::<4>(buf, pos).map(i32::from_le_bytes)
}

pub(crate) fn i64_at(buf: &[u8], pos: usize) -> Result<i64, FbError> {
    take::<8>(buf, pos).map(i64::from_le_bytes)
}

/// Follows the `uoffset` stored at `pos`.
fn follow(buf: &[u8], pos: usize) -> Result<usize, FbError> {
    let off = u32_at(buf, pos)? as usize;
    pos.checked_add(off)
        .filter(|&p| p < buf.len())
        .ok_or_else(|| bad(pos, "offset points past the end of the buffer"))
}

/// A table of a buffer.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Table<'a> {
    buf: &'a [u8],
    pos: usize,
    vtable: usize,
    vtable_len: usize,
}

impl<'a> Table<'a> {
    /// The root table of `buf`, and its file identifier (the 4 bytes after the root offset).
    pub fn root(buf: &'a [u8]) -> Result<(Self, [u8; 4]), FbError> {
        let ident = take::<4>(buf, 4)?;
        Ok((Self::at(buf, follow(buf, 0)?)?, ident))
    }

    fn at(buf: &'a [u8], pos: usize) -> Result<Self, FbError> {
        let soffset = i64::from(i32_at(buf, pos)?);
        let vtable = usize::try_from(pos as i64 - soffset)
            .ok()
            .filter(|&v| v < buf.len())
            .ok_or_else(|| bad(pos, "table's vtable lies outside the buffer"))?;
        let vtable_len = usize::from(u16_at(buf, vtable)?);
        if vtable_len < 4 || vtable_len % 2 != 0 || vtable + vtable_len > buf.len() {
            return Err(bad(vtable, "malformed vtable"));
        }
        Ok(Self {
            buf,
            pos,
            vtable,
            vtable_len,
        })
    }

    /// Where field `id` is stored, if present.
    fn field(&self, id: usize) -> Result<Option<usize>, FbError> {
        let entry = 4 + 2 * id;
        if entry + 2 > self.vtable_len {
            return Ok(None);
        }
        let off = u16_at(self.buf, self.vtable + entry)?;
        Ok((off != 0).then(|| self.pos + usize::from(off)))
    }

    pub fn i32(&self, id: usize, default: i32) -> Result<i32, FbError> {
        self.field(id)?
            .map_or(Ok(default), |pos| i32_at(self.buf, pos))
    }

    pub fn i64(&self, id: usize, default: i64) -> Result<i64, FbError> {
        self.field(id)?
            .map_or(Ok(default), |pos| i64_at(self.buf, pos))
    }

    /// A `string` field's bytes (without the NUL).
    pub fn string(&self, id: usize) -> Result<Option<&'a [u8]>, FbError> {
        self.vector(id, 1)
            .map(|v| v.map(|(start, n)| &self.buf[start..start + n]))
    }

    /// A vector field of `elem`-byte elements: where its elements start and how many.
    pub fn vector(&self, id: usize, elem: usize) -> Result<Option<(usize, usize)>, FbError> {
        let Some(pos) = self.field(id)? else {
            return Ok(None);
        };
        let start = follow(self.buf, pos)?;
        let n = u32_at(self.buf, start)? as usize;
        let data = start + 4;
        if n.checked_mul(elem)
            .and_then(|len| data.checked_add(len))
            .is_none_or(|end| end > self.buf.len())
        {
            return Err(bad(start, "vector runs past the end of the buffer"));
        }
        Ok(Some((data, n)))
    }
}

/// Writes a size-prefixed buffer whose root table has one vector-of-structs field (field 0):
/// AEDAT4's `EventPacket`. `elements` are the structs' bytes (`elem_align`-aligned, at most 8),
/// `n` their count. Alignment counts from the size prefix, as FlatBuffers' builders do.
pub(crate) fn one_vector_table(ident: &[u8; 4], n: usize, elements: &[u8]) -> Vec<u8> {
    // 0 size · 4 root · 8 ident · 12 vtable (6 bytes) · 18 pad · 20 table (soffset, uoffset) ·
    // 28 vector length · 32 elements (8-aligned).
    let mut b = Vec::with_capacity(32 + elements.len());
    b.extend_from_slice(&0u32.to_le_bytes());
    b.extend_from_slice(&(20u32 - 4).to_le_bytes());
    b.extend_from_slice(ident);
    for v in [6u16, 8, 4, 0] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    b.extend_from_slice(&(20i32 - 12).to_le_bytes());
    b.extend_from_slice(&4u32.to_le_bytes());
    b.extend_from_slice(&u32::try_from(n).unwrap_or(u32::MAX).to_le_bytes());
    b.extend_from_slice(elements);
    finish(b)
}

/// Writes AEDAT4's size-prefixed `IOHeader`: `compression` (field 0), `dataTablePosition`
/// (field 1), `infoNode` (field 2).
pub(crate) fn io_header(compression: i32, data_table_position: i64, info: &str) -> Vec<u8> {
    // 0 size · 4 root · 8 ident · 12 vtable (10 bytes) · 22 pad · 28 table: soffset,
    // compression, infoNode uoffset, dataTablePosition (8-aligned at 40) · 48 string.
    let mut b = Vec::with_capacity(64 + info.len());
    b.extend_from_slice(&0u32.to_le_bytes());
    b.extend_from_slice(&(28u32 - 4).to_le_bytes());
    b.extend_from_slice(b"IOHE");
    for v in [10u16, 20, 4, 12, 8, 0, 0, 0] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    b.extend_from_slice(&(28i32 - 12).to_le_bytes());
    b.extend_from_slice(&compression.to_le_bytes());
    b.extend_from_slice(&(48u32 - 36).to_le_bytes());
    b.extend_from_slice(&data_table_position.to_le_bytes());
    b.extend_from_slice(&u32::try_from(info.len()).unwrap_or(u32::MAX).to_le_bytes());
    b.extend_from_slice(info.as_bytes());
    b.push(0);
    finish(b)
}

/// Pads to a multiple of 8 and fills in the size prefix.
fn finish(mut b: Vec<u8>) -> Vec<u8> {
    b.resize(b.len().next_multiple_of(8), 0);
    let size = u32::try_from(b.len() - 4).unwrap_or(u32::MAX);
    b[..4].copy_from_slice(&size.to_le_bytes());
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn written_tables_read_back_and_bad_offsets_are_caught() {
        let h = io_header(3, -1, "<dv/>");
        assert_eq!(u32_at(&h, 0).unwrap() as usize, h.len() - 4);
        let (t, ident) = Table::root(&h[4..]).unwrap();
        assert_eq!(&ident, b"IOHE");
        assert_eq!(t.i32(0, 0).unwrap(), 3);
        assert_eq!(t.i64(1, 0).unwrap(), -1);
        assert_eq!(t.string(2).unwrap(), Some(&b"<dv/>"[..]));
        assert_eq!(t.i32(7, 42).unwrap(), 42, "an absent field has its default");
        let p = one_vector_table(b"EVTS", 2, &[7; 32]);
        let (t, ident) = Table::root(&p[4..]).unwrap();
        assert_eq!(&ident, b"EVTS");
        let (start, n) = t.vector(0, 16).unwrap().unwrap();
        assert_eq!(
            (start + 4, n),
            (32, 2),
            "elements 8-aligned from the size prefix"
        );
        assert!(t.vector(0, 17).is_err(), "a vector longer than the buffer");
        let mut bad = p.clone();
        bad[4..8].copy_from_slice(&1000u32.to_le_bytes());
        assert!(Table::root(&bad[4..]).is_err());
    }
}
