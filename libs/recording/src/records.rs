//! The MCAP records the reader parses, checked before the `mcap` crate parses them.
//!
//! `mcap` (through `binrw`) reserves a string's or a byte array's whole length as soon as it has
//! read its `u32` length prefix, before it knows whether the record holds that many bytes: a
//! record of a few bytes claiming a 4 GiB topic name makes it allocate 4 GiB. [`parse`] first
//! walks every length-prefixed field of the records Waggle uses (header, schema, channel,
//! message, metadata, data end, footer) and refuses one that runs past its record, naming the
//! field; records Waggle does not use (indexes, statistics, attachments, summary offsets) are
//! not parsed at all.

use mcap::records::{Record, op};
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};

/// Walks the fields of one record body, refusing a length past its end.
struct Fields<'a> {
    body: &'a [u8],
    at: usize,
}

impl Fields<'_> {
    fn fixed(&mut self, n: usize, what: &str) -> Result<(), String> {
        if self.body.len() - self.at < n {
            return Err(format!(
                "{what} ({n} bytes at byte {}) runs past the {}-byte record",
                self.at,
                self.body.len()
            ));
        }
        self.at += n;
        Ok(())
    }

    /// A `u32` length prefix, then that many bytes; returns the length.
    fn prefixed(&mut self, what: &str) -> Result<usize, String> {
        let at = self.at;
        self.fixed(4, what)?;
        let len = u32::from_le_bytes(self.body[at..at + 4].try_into().expect("4 bytes")) as usize;
        if self.body.len() - self.at < len {
            return Err(format!(
                "{what} claims {len} bytes at byte {at}, but the record has {} left",
                self.body.len() - self.at
            ));
        }
        self.at += len;
        Ok(len)
    }

    /// A string map: its byte length, then key and value strings until that many are read.
    fn map(&mut self, what: &str) -> Result<(), String> {
        let start = self.at + 4;
        let len = self.prefixed(what)?;
        self.at = start;
        while self.at - start < len {
            self.prefixed(&format!("a key of {what}"))?;
            self.prefixed(&format!("a value of {what}"))?;
        }
        Ok(())
    }
}

/// Checks that every length-prefixed field of a record Waggle parses fits in `body`.
fn check(opcode: u8, body: &[u8]) -> Result<(), String> {
    let mut f = Fields { body, at: 0 };
    match opcode {
        op::HEADER => {
            f.prefixed("the profile")?;
            f.prefixed("the library")?;
        }
        op::SCHEMA => {
            f.fixed(2, "the schema id")?;
            f.prefixed("the schema name")?;
            f.prefixed("the schema encoding")?;
            f.prefixed("the schema data")?;
        }
        op::CHANNEL => {
            f.fixed(4, "the channel and schema ids")?;
            f.prefixed("the topic")?;
            f.prefixed("the message encoding")?;
            f.map("the channel metadata")?;
        }
        op::MESSAGE => f.fixed(2 + 4 + 8 + 8, "the message header")?,
        op::METADATA => {
            f.prefixed("the metadata name")?;
            f.map("the metadata")?;
        }
        op::DATA_END => f.fixed(4, "the data section CRC")?,
        op::FOOTER => f.fixed(8 + 8 + 4, "the footer")?,
        _ => {}
    }
    Ok(())
}

/// True for the records Waggle reads (the others are skipped unparsed).
pub fn is_used(opcode: u8) -> bool {
    matches!(
        opcode,
        op::HEADER
            | op::SCHEMA
            | op::CHANNEL
            | op::MESSAGE
            | op::METADATA
            | op::DATA_END
            | op::FOOTER
    )
}

/// Parses one record (opcode and body) that Waggle uses, after checking its length-prefixed
/// fields; `Ok(None)` for a record Waggle does not use.
pub fn parse(opcode: u8, body: &[u8]) -> Result<Option<Record<'_>>, String> {
    if !is_used(opcode) {
        return Ok(None);
    }
    check(opcode, body)?;
    mcap::parse_record(opcode, body)
        .map(Some)
        .map_err(|e| e.to_string())
}

/// Largest chunk accepted, uncompressed: the writer's chunks are 4 MiB, or one message larger
/// than that (a raw RGB frame is 0.9 MB); a chunk header claiming more is refused before its
/// buffer is allocated.
pub const CHUNK_LIMIT_BYTES: usize = 64 << 20;

/// Bytes of a chunk record body before its compression string: start and end time,
/// uncompressed size, uncompressed CRC.
const CHUNK_FIXED_BYTES: usize = 8 + 8 + 8 + 4;

/// Checks a chunk record's (`bytes`: opcode, length, body) claimed sizes and, when it is not
/// compressed, the framing of the records in it.
fn check_chunk(bytes: &[u8]) -> Result<(), String> {
    let body = bytes.get(9..).unwrap_or_default();
    let mut f = Fields { body, at: 0 };
    f.fixed(CHUNK_FIXED_BYTES, "the chunk header")?;
    let uncompressed = u64::from_le_bytes(body[16..24].try_into().expect("8 bytes"));
    if uncompressed > CHUNK_LIMIT_BYTES as u64 {
        return Err(format!(
            "the chunk claims {uncompressed} bytes uncompressed, more than the \
             {CHUNK_LIMIT_BYTES} a chunk may hold"
        ));
    }
    let compressed = f.prefixed("the compression")? > 0;
    let records_at = f.at + 8;
    f.fixed(8, "the records length")?;
    let len = u64::from_le_bytes(
        body[records_at - 8..records_at]
            .try_into()
            .expect("8 bytes"),
    );
    let records = &body[records_at..];
    if len != records.len() as u64 {
        return Err(format!(
            "the chunk's records claim {len} bytes, but {} follow",
            records.len()
        ));
    }
    if compressed {
        return Ok(());
    }
    let mut at = 0;
    while at < records.len() {
        let head = records
            .get(at..at + 9)
            .ok_or_else(|| format!("a record header is cut at byte {at} of the chunk's records"))?;
        let n = u64::from_le_bytes(head[1..9].try_into().expect("8 bytes"));
        let left = (records.len() - at - 9) as u64;
        if n > left {
            return Err(format!(
                "a record of {n} bytes at byte {at} of the chunk's records runs past its {left} \
                 remaining bytes"
            ));
        }
        at += 9 + n as usize;
    }
    Ok(())
}

/// The records inside one chunk record (`bytes`: opcode, length, body), decompressed and
/// checked against the chunk's CRC before any is returned. A chunk claiming more than
/// [`CHUNK_LIMIT_BYTES`] uncompressed is refused before anything is allocated for it, and the
/// records of an uncompressed chunk must each fit in it (`mcap` would otherwise count the bytes
/// left below zero).
pub fn chunk_records(bytes: &[u8]) -> Result<Vec<(u8, Vec<u8>)>, String> {
    check_chunk(bytes)?;
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_skip_start_magic(true)
            .with_skip_end_magic(true)
            .with_prevalidate_chunk_crcs(true)
            .with_record_length_limit(CHUNK_LIMIT_BYTES),
    );
    let mut fed = false;
    let mut out = Vec::new();
    while let Some(event) = reader.next_event() {
        match event.map_err(|e| e.to_string())? {
            LinearReadEvent::ReadRequest(need) => {
                if fed {
                    reader.notify_read(0);
                } else {
                    let n = need.max(bytes.len());
                    let buf = reader.insert(n);
                    buf[..bytes.len()].copy_from_slice(bytes);
                    reader.notify_read(bytes.len());
                    fed = true;
                }
            }
            LinearReadEvent::Record { data, opcode } => out.push((opcode, data.to_vec())),
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_length_past_the_record_is_refused_before_parsing() {
        // Channel 1 of schema 0, topic length 0x6E6C6F6E (1.85 GB) in a 12-byte record.
        let body = [1, 0, 0, 0, 0x6E, 0x6F, 0x6C, 0x6E, b'/', b'x', 0, 0];
        let e = parse(op::CHANNEL, &body).unwrap_err();
        assert!(
            e.contains("the topic claims 1852600174 bytes at byte 4"),
            "{e}"
        );
        let mut good = vec![1, 0, 0, 0];
        for s in ["/x", "waggle-proto"] {
            good.extend((s.len() as u32).to_le_bytes());
            good.extend(s.as_bytes());
        }
        good.extend(0u32.to_le_bytes());
        assert!(matches!(
            parse(op::CHANNEL, &good),
            Ok(Some(Record::Channel(_)))
        ));
        // A map whose key claims more than the record holds.
        let mut bad_map = good[..good.len() - 4].to_vec();
        bad_map.extend(8u32.to_le_bytes());
        bad_map.extend(u32::MAX.to_le_bytes());
        bad_map.extend([0; 4]);
        let e = parse(op::CHANNEL, &bad_map).unwrap_err();
        assert!(e.contains("a key of the channel metadata"), "{e}");
        assert!(matches!(parse(op::STATISTICS, &[0xFF; 3]), Ok(None)));
    }
}
