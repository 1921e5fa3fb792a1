//! Reading a recording back, chunk by chunk, tolerating a cut or damaged tail.
//!
//! The file is streamed (memory stays at about one chunk) with chunk CRCs checked before any
//! record of a chunk is handed out, so a truncated or corrupt recording yields every message of
//! the chunks before the damage and then stops with [`ReadOutcome::complete`] false and the
//! reason — never a panic.

use std::collections::BTreeMap;
use std::io::Read;
use std::path::Path;

use mcap::records::{Record, op};
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};

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

/// How far a recording could be read.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ReadOutcome {
    /// The whole file was read, through its footer and closing magic.
    pub complete: bool,
    /// Why reading stopped early (truncation, corruption), when it did.
    pub problem: Option<String>,
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

/// Streams every message of `path` to `visit`, in file order. A visitor error stops reading
/// and is returned as is.
pub fn read_recording<E: From<ReadError>>(
    path: &Path,
    mut visit: impl FnMut(&RecordedMessage<'_>) -> Result<(), E>,
) -> Result<ReadOutcome, E> {
    let shown = path.display().to_string();
    let mut file = std::fs::File::open(path).map_err(|source| ReadError::Io {
        path: shown.clone(),
        source,
    })?;
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_prevalidate_chunk_crcs(true)
            .with_record_length_limit(RECORD_LIMIT_BYTES),
    );
    let mut out = ReadOutcome::default();
    let mut schemas: BTreeMap<u16, String> = BTreeMap::new();
    let mut channels: BTreeMap<u16, ChannelInfo> = BTreeMap::new();
    let mut saw_footer = false;
    let mut any_record = false;
    while let Some(event) = reader.next_event() {
        let event = match event {
            Ok(e) => e,
            Err(e) => {
                if !any_record {
                    return Err(ReadError::NotMcap {
                        path: shown,
                        reason: e.to_string(),
                    }
                    .into());
                }
                out.problem = Some(format!("stopped after {} messages: {e}", out.messages));
                return Ok(out);
            }
        };
        match event {
            LinearReadEvent::ReadRequest(need) => {
                let n = match file.read(reader.insert(need)) {
                    Ok(n) => n,
                    Err(source) => {
                        return Err(ReadError::Io {
                            path: shown,
                            source,
                        }
                        .into());
                    }
                };
                reader.notify_read(n);
            }
            LinearReadEvent::Record { data, opcode } => {
                any_record = true;
                if opcode == op::FOOTER {
                    saw_footer = true;
                }
                let record = match mcap::parse_record(opcode, data) {
                    Ok(r) => r,
                    Err(e) => {
                        out.problem = Some(format!(
                            "record {opcode:#04x} after {} messages does not parse: {e}",
                            out.messages
                        ));
                        return Ok(out);
                    }
                };
                match record {
                    Record::Schema { header, .. } => {
                        schemas.insert(header.id, header.name);
                    }
                    Record::Channel(c) => {
                        channels.insert(
                            c.id,
                            ChannelInfo {
                                topic: c.topic,
                                schema_id: c.schema_id,
                                encoding: c.message_encoding,
                            },
                        );
                    }
                    Record::Message { header, data } => {
                        let Some(c) = channels.get(&header.channel_id) else {
                            out.orphan_messages += 1;
                            continue;
                        };
                        out.messages += 1;
                        visit(&RecordedMessage {
                            topic: &c.topic,
                            schema: schemas.get(&c.schema_id).map_or("", String::as_str),
                            message_encoding: &c.encoding,
                            log_time_ns: header.log_time,
                            publish_time_ns: header.publish_time,
                            data: &data,
                        })?;
                    }
                    Record::Metadata(m) => {
                        out.metadata.insert(m.name, m.metadata);
                    }
                    _ => {}
                }
            }
        }
    }
    out.complete = saw_footer;
    if !saw_footer {
        out.problem = Some(format!(
            "no footer after {} messages: the recording was cut short",
            out.messages
        ));
    }
    Ok(out)
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
                let n = file.read(reader.insert(need)).map_err(io)?;
                reader.notify_read(n);
            }
            Ok(LinearReadEvent::Record { data, opcode }) => {
                match mcap::parse_record(opcode, data) {
                    Ok(Record::Metadata(m)) if m.name == name => return Ok(Some(m.metadata)),
                    Ok(Record::Message { .. }) => return Ok(None),
                    Ok(_) => {}
                    Err(e) => {
                        return Err(ReadError::NotMcap {
                            path: shown,
                            reason: e.to_string(),
                        });
                    }
                }
            }
        }
    }
    Ok(None)
}
