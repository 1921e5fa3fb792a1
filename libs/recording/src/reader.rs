//! Reading a recording back, chunk by chunk, tolerating a cut or damaged tail.
//!
//! The file is read record by record (memory stays at about one chunk) with chunk CRCs checked
//! before any record of a chunk is handed out. A damaged chunk is skipped; broken framing (a
//! garbled length, a cut) makes the reader search for the next intact chunk and resume there.
//! Each skipped stretch is reported with its byte range and the log times around it, the data
//! and summary section CRCs are verified, and [`ReadOutcome::complete`] is true only for an
//! intact file — never a panic.

use std::collections::BTreeMap;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

use mcap::records::{Record, op};
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};

use crate::records;

/// One recorded message, borrowed from the reader.
#[derive(Debug, Clone, Copy)]
pub struct RecordedMessage<'a> {
    pub topic: &'a str,
    /// Schema name (`waggle.EventPacket`, `foxglove.Log`, …; empty without a schema).
    pub schema: &'a str,
    pub message_encoding: &'a str,
    pub log_time_ns: u64,
    pub publish_time_ns: u64,
    pub data: &'a [u8],
}

/// A stretch of a recording that could not be read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Damage {
    /// Byte range `[from_byte, to_byte)` skipped.
    pub from_byte: u64,
    pub to_byte: u64,
    /// Log time of the last message read before it, ns (`None`: none before).
    pub after_ns: Option<u64>,
    /// Log time of the first message read after it, ns (`None`: nothing after).
    pub resumed_ns: Option<u64>,
    pub reason: String,
}

impl std::fmt::Display for Damage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = |t: Option<u64>| t.map_or("-".to_string(), |t| format!("{:.3} s", t as f64 * 1e-9));
        write!(
            f,
            "bytes {}..{} ({}; messages from {} to {} lost{})",
            self.from_byte,
            self.to_byte,
            self.reason,
            s(self.after_ns),
            s(self.resumed_ns),
            if self.resumed_ns.is_some() {
                ", resumed at the next intact chunk"
            } else {
                ""
            }
        )
    }
}

/// How far a recording could be read.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ReadOutcome {
    /// The whole file was read, through its footer and closing magic, without damage and with
    /// matching data and summary CRCs.
    pub complete: bool,
    /// Why it is not complete (every damaged stretch, a CRC mismatch, a missing footer).
    pub problem: Option<String>,
    /// The stretches skipped; reading resumed at the next intact chunk after each.
    pub damaged: Vec<Damage>,
    /// Log time of the last message read before the first damage, ns: the recording covers
    /// the run without gaps up to there.
    pub first_damage_ns: Option<u64>,
    /// The data section's CRC (`None`: not stored, or not checkable after damage).
    pub data_crc_ok: Option<bool>,
    /// The summary section's CRC (`None`: no footer, or not stored).
    pub summary_crc_ok: Option<bool>,
    /// Metadata records by name.
    pub metadata: BTreeMap<String, BTreeMap<String, String>>,
    pub messages: u64,
    /// Messages on a channel that was never declared (skipped).
    pub orphan_messages: u64,
}

/// Why a file could not be read at all.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    #[error("reading {path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{path} is not an MCAP file: {reason}")]
    NotMcap { path: String, reason: String },
}

struct ChannelInfo {
    topic: String,
    schema_id: u16,
    encoding: String,
}

/// Largest record accepted (a chunk is bounded by the writer's chunk size; a single message may
/// exceed it, e.g. a raw RGB frame).
const RECORD_LIMIT_BYTES: usize = 1 << 30;
/// Bytes of a chunk record before its compression string: start and end time, uncompressed
/// size, uncompressed CRC.
const CHUNK_FIXED_BYTES: u64 = 8 + 8 + 8 + 4;

/// Schemas, channels and the outcome while reading.
struct Reading {
    schemas: BTreeMap<u16, String>,
    channels: BTreeMap<u16, ChannelInfo>,
    out: ReadOutcome,
    last_log_ns: Option<u64>,
    /// A damage whose first message after it is still to come.
    open_damage: Option<usize>,
    /// CRC of the data section so far (magic and every record before `DataEnd`).
    data_crc: crc32fast::Hasher,
    /// Where `DataEnd` starts: the data section is the bytes before it.
    data_end_byte: u64,
    in_data: bool,
    /// CRC of the summary section so far (every record after `DataEnd`).
    summary_crc: crc32fast::Hasher,
    saw_footer: bool,
}

impl Reading {
    fn damage(&mut self, from_byte: u64, to_byte: u64, reason: String) {
        if self.out.damaged.is_empty() {
            self.out.first_damage_ns = Some(self.last_log_ns.unwrap_or(0));
        }
        self.out.damaged.push(Damage {
            from_byte,
            to_byte,
            after_ns: self.last_log_ns,
            resumed_ns: None,
            reason,
        });
        self.open_damage = Some(self.out.damaged.len() - 1);
    }

    /// Handles one top-level record (`record`: opcode, length, body) at `[at.0, at.1)`.
    fn top_level<E>(
        &mut self,
        opcode: u8,
        record: &[u8],
        (pos, next): (u64, u64),
        visit: &mut impl FnMut(&RecordedMessage<'_>) -> Result<(), E>,
    ) -> Result<(), E> {
        match opcode {
            op::CHUNK => match records::chunk_records(record) {
                Ok(inner) => {
                    for (op_inner, data) in inner {
                        match records::parse(op_inner, &data) {
                            Ok(Some(rec)) => self.record(rec, visit)?,
                            Ok(None) => {}
                            Err(e) => {
                                let why = format!("record in a chunk does not parse: {e}");
                                self.damage(pos, next, why);
                                break;
                            }
                        }
                    }
                }
                Err(e) => self.damage(pos, next, format!("chunk: {e}")),
            },
            _ => match records::parse(opcode, &record[9..]) {
                Ok(None) => {}
                Ok(Some(Record::DataEnd(d))) => {
                    self.data_end_byte = pos;
                    if d.data_section_crc != 0 && self.out.damaged.is_empty() {
                        let ok = d.data_section_crc == self.data_crc.clone().finalize();
                        self.out.data_crc_ok = Some(ok);
                    }
                }
                Ok(Some(Record::Footer(f))) => {
                    self.saw_footer = true;
                    if f.summary_crc != 0 {
                        // The summary CRC covers the summary sections and the footer up to
                        // its own CRC field.
                        self.summary_crc.update(&record[..9 + 8 + 8]);
                        let ok = f.summary_crc == self.summary_crc.clone().finalize();
                        self.out.summary_crc_ok = Some(ok);
                    }
                }
                Ok(Some(rec)) => self.record(rec, visit)?,
                Err(e) => self.damage(
                    pos,
                    next,
                    format!("record {opcode:#04x} does not parse: {e}"),
                ),
            },
        }
        Ok(())
    }

    /// The outcome, with every problem named.
    fn finish(mut self) -> ReadOutcome {
        let mut problems: Vec<String> = self.out.damaged.iter().map(|d| d.to_string()).collect();
        if self.out.data_crc_ok == Some(false) {
            // No record failed to parse, so the damage is somewhere in the section's bytes.
            problems.push(format!(
                "the data section's CRC (bytes 0..{}) does not match",
                self.data_end_byte
            ));
        }
        if self.out.summary_crc_ok == Some(false) {
            problems.push("the summary section CRC does not match".into());
        }
        if !self.saw_footer {
            problems.push(format!(
                "no footer after {} messages: the recording was cut short",
                self.out.messages
            ));
        }
        self.out.complete = problems.is_empty();
        self.out.problem = (!problems.is_empty()).then(|| problems.join("; "));
        self.out
    }

    /// Handles one record (top level or inside a chunk).
    fn record<E>(
        &mut self,
        record: Record<'_>,
        visit: &mut impl FnMut(&RecordedMessage<'_>) -> Result<(), E>,
    ) -> Result<(), E> {
        match record {
            Record::Schema { header, .. } => {
                self.schemas.insert(header.id, header.name);
            }
            Record::Channel(c) => {
                self.channels.insert(
                    c.id,
                    ChannelInfo {
                        topic: c.topic,
                        schema_id: c.schema_id,
                        encoding: c.message_encoding,
                    },
                );
            }
            Record::Message { header, data } => {
                let Some(c) = self.channels.get(&header.channel_id) else {
                    self.out.orphan_messages += 1;
                    return Ok(());
                };
                self.out.messages += 1;
                if let Some(i) = self.open_damage.take() {
                    self.out.damaged[i].resumed_ns = Some(header.log_time);
                }
                self.last_log_ns = Some(header.log_time);
                visit(&RecordedMessage {
                    topic: &c.topic,
                    schema: self.schemas.get(&c.schema_id).map_or("", String::as_str),
                    message_encoding: &c.encoding,
                    log_time_ns: header.log_time,
                    publish_time_ns: header.publish_time,
                    data: &data,
                })?;
            }
            Record::Metadata(m) => {
                self.out.metadata.insert(m.name, m.metadata);
            }
            _ => {}
        }
        Ok(())
    }
}

/// True when `body` (a record body following opcode `CHUNK`) looks like a chunk: a known
/// compression and a records length that fills the record exactly.
fn plausible_chunk(body_len: u64, head: &[u8]) -> bool {
    let at = CHUNK_FIXED_BYTES as usize;
    let Some(len_bytes) = head.get(at..at + 4) else {
        return false;
    };
    let n = u32::from_le_bytes(len_bytes.try_into().expect("4 bytes")) as usize;
    if n > 8 {
        return false;
    }
    let Some(name) = head.get(at + 4..at + 4 + n) else {
        return false;
    };
    if !matches!(name, b"" | b"zstd" | b"lz4") {
        return false;
    }
    let Some(rl) = head.get(at + 4 + n..at + 4 + n + 8) else {
        return false;
    };
    let records_len = u64::from_le_bytes(rl.try_into().expect("8 bytes"));
    (CHUNK_FIXED_BYTES + 4 + n as u64 + 8).checked_add(records_len) == Some(body_len)
}

/// The file, read at arbitrary offsets (resynchronisation seeks).
struct Source<R> {
    file: R,
    len: u64,
}

impl<R: Read + Seek> Source<R> {
    fn read_at(&mut self, pos: u64, buf: &mut [u8]) -> std::io::Result<()> {
        self.file.seek(SeekFrom::Start(pos))?;
        self.file.read_exact(buf)
    }

    /// The next offset after `from` where an intact chunk record starts, with its bytes.
    fn next_chunk(&mut self, from: u64) -> std::io::Result<Option<(u64, Vec<u8>)>> {
        const WINDOW: u64 = 1 << 20;
        const HEAD: u64 = 9 + CHUNK_FIXED_BYTES + 4 + 8 + 8;
        let mut start = from;
        while start + HEAD <= self.len {
            let n = WINDOW.min(self.len - start);
            let mut window = vec![0u8; n as usize];
            self.read_at(start, &mut window)?;
            for (i, &b) in window.iter().enumerate() {
                if b != op::CHUNK {
                    continue;
                }
                let q = start + i as u64;
                if q + HEAD > self.len {
                    return Ok(None);
                }
                let mut head = vec![0u8; HEAD as usize];
                self.read_at(q, &mut head)?;
                let body_len = u64::from_le_bytes(head[1..9].try_into().expect("8 bytes"));
                if body_len > RECORD_LIMIT_BYTES as u64
                    || q + 9 + body_len > self.len
                    || !plausible_chunk(body_len, &head[9..])
                {
                    continue;
                }
                let mut record = vec![0u8; (9 + body_len) as usize];
                self.read_at(q, &mut record)?;
                if records::chunk_records(&record).is_ok() {
                    return Ok(Some((q, record)));
                }
            }
            // Overlap the windows so a header across their border is still seen.
            start += n.saturating_sub(HEAD).max(1);
        }
        Ok(None)
    }
}

/// Streams every message of `path` to `visit`, in file order. Chunk CRCs are checked before
/// any message of a chunk is handed out; a damaged chunk (or broken record framing) is
/// skipped, reported with its byte and time range, and reading resumes at the next intact
/// chunk; the data and summary section CRCs are verified when stored. A visitor error stops
/// reading and is returned as is.
pub fn read_recording<E: From<ReadError>>(
    path: &Path,
    visit: impl FnMut(&RecordedMessage<'_>) -> Result<(), E>,
) -> Result<ReadOutcome, E> {
    let shown = path.display().to_string();
    let io = |source| ReadError::Io {
        path: shown.clone(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io)?;
    read_recording_from(file, &shown, visit)
}

/// [`read_recording`] over any seekable byte source (a file, or bytes in memory); `shown` names
/// the source in errors.
pub fn read_recording_from<E: From<ReadError>>(
    mut file: impl Read + Seek,
    shown: &str,
    mut visit: impl FnMut(&RecordedMessage<'_>) -> Result<(), E>,
) -> Result<ReadOutcome, E> {
    let io = |source| ReadError::Io {
        path: shown.to_string(),
        source,
    };
    let len = file.seek(SeekFrom::End(0)).map_err(io)?;
    let mut src = Source { file, len };
    let not_mcap = |reason: &str| ReadError::NotMcap {
        path: shown.to_string(),
        reason: reason.to_string(),
    };
    let mut magic = [0u8; 8];
    if len < 8 || src.read_at(0, &mut magic).is_err() || magic != *mcap::MAGIC {
        return Err(not_mcap("no MCAP magic at the start").into());
    }
    let mut r = Reading {
        schemas: BTreeMap::new(),
        channels: BTreeMap::new(),
        out: ReadOutcome::default(),
        last_log_ns: None,
        open_damage: None,
        data_crc: crc32fast::Hasher::new(),
        data_end_byte: 0,
        in_data: true,
        summary_crc: crc32fast::Hasher::new(),
        saw_footer: false,
    };
    r.data_crc.update(&magic);
    let mut saw_footer = false;
    let mut pos = 8u64;
    while pos < len {
        if saw_footer {
            let mut end = [0u8; 8];
            let ok = len - pos == 8 && src.read_at(pos, &mut end).is_ok() && end == *mcap::MAGIC;
            if !ok {
                r.damage(
                    pos,
                    len,
                    "bytes after the footer are not the closing magic".into(),
                );
            }
            break;
        }
        let mut header = [0u8; 9];
        if len - pos < 9 {
            r.damage(pos, len, "cut inside a record header".into());
            break;
        }
        src.read_at(pos, &mut header).map_err(io)?;
        let opcode = header[0];
        let body_len = u64::from_le_bytes(header[1..9].try_into().expect("8 bytes"));
        let fits = body_len <= RECORD_LIMIT_BYTES as u64 && pos + 9 + body_len <= len;
        if !fits {
            // Either the file was cut inside this record, or its header is garbage: look for
            // the next intact chunk either way.
            match src.next_chunk(pos + 1).map_err(io)? {
                Some((q, _)) => {
                    r.damage(
                        pos,
                        q,
                        format!("record {opcode:#04x} does not fit the file"),
                    );
                    pos = q;
                    continue;
                }
                None => {
                    r.damage(
                        pos,
                        len,
                        "cut short (a record runs past the end of the file)".into(),
                    );
                    break;
                }
            }
        }
        let mut record = vec![0u8; (9 + body_len) as usize];
        src.read_at(pos, &mut record).map_err(io)?;
        let next = pos + 9 + body_len;
        if opcode == op::DATA_END {
            r.in_data = false;
        } else if r.in_data {
            r.data_crc.update(&record);
        } else if opcode != op::FOOTER {
            r.summary_crc.update(&record);
        }
        r.top_level(opcode, &record, (pos, next), &mut visit)?;
        saw_footer = r.saw_footer;
        pos = next;
    }
    Ok(r.finish())
}

/// The metadata record `name` if it precedes the first message (the writer puts the session
/// metadata there), without reading the rest of the file.
pub fn leading_metadata(
    path: &Path,
    name: &str,
) -> Result<Option<BTreeMap<String, String>>, ReadError> {
    let shown = path.display().to_string();
    let io = |source| ReadError::Io {
        path: shown.clone(),
        source,
    };
    let mut file = std::fs::File::open(path).map_err(io)?;
    // What the file still holds: a record's claimed length never sizes a buffer beyond it.
    let mut left = file.metadata().map_err(io)?.len();
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default().with_record_length_limit(RECORD_LIMIT_BYTES),
    );
    while let Some(event) = reader.next_event() {
        match event {
            Err(e) => {
                return Err(ReadError::NotMcap {
                    path: shown,
                    reason: e.to_string(),
                });
            }
            Ok(LinearReadEvent::ReadRequest(need)) => {
                let want = need.min(usize::try_from(left).unwrap_or(usize::MAX));
                let n = if want == 0 {
                    0
                } else {
                    file.read(reader.insert(want)).map_err(io)?
                };
                left -= n as u64;
                reader.notify_read(n);
            }
            Ok(LinearReadEvent::Record { data, opcode }) => match records::parse(opcode, data) {
                Ok(Some(Record::Metadata(m))) if m.name == name => {
                    return Ok(Some(m.metadata));
                }
                Ok(Some(Record::Message { .. })) => return Ok(None),
                Ok(_) => {}
                Err(e) => {
                    return Err(ReadError::NotMcap {
                        path: shown,
                        reason: e.to_string(),
                    });
                }
            },
        }
    }
    Ok(None)
}
