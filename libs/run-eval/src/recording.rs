//! Session recordings (`DIR/session.mcap`, written by `recorder-node`): reading a recording's
//! raw Waggle messages back for `waggle replay` and `waggle audit`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use proto::{Key, ObserverId};
use recording::{
    Decoded, MessageKind, RAW_ENCODING, ReadOutcome, SESSION_METADATA, SessionInfo,
    UnrecordedPackets, decode, read_recording,
};

use run_format::case::Case;
use run_format::run_dir::RECORDING_FILE;

/// A recording path: a `.mcap` file, or a run directory holding `session.mcap`.
pub fn resolve(path: &Path) -> PathBuf {
    if path.is_dir() {
        path.join(RECORDING_FILE)
    } else {
        path.to_path_buf()
    }
}

/// One decoded raw message of a recording.
pub struct Item<'a> {
    /// Channel topic (`/sensor/O1/events`, …).
    pub topic: &'a str,
    pub msg: Decoded,
}

/// The key of a channel: a topic is the key without its `waggle/<session>` prefix, so it
/// parses with the one key grammar ([`Key::parse_rest`]).
pub fn topic_key(topic: &str) -> Option<Key> {
    Key::parse_rest(topic.strip_prefix('/')?)
}

/// The observer a channel belongs to (`/sensor/O1/events` → `O1`), if any.
pub fn topic_observer(topic: &str) -> Option<ObserverId> {
    topic_key(topic)?.observer().cloned()
}

/// What a scan of a recording found besides its messages.
#[derive(Debug, Clone)]
pub struct Scan {
    pub outcome: ReadOutcome,
    pub info: SessionInfo,
    /// Raw messages that did not decode (skipped).
    pub undecodable: u64,
}

impl Scan {
    /// The recording's case, parsed from the TOML it holds.
    pub fn case(&self) -> Result<Option<Case>> {
        let Some(text) = &self.info.case_toml else {
            return Ok(None);
        };
        let case: Case =
            toml::from_str(text).context("parsing the case stored in the recording")?;
        Ok(Some(case))
    }
}

/// Streams every raw Waggle message of the recording at `path` (a file or a run directory),
/// decoded with `proto::decode`, to `visit`; view channels are skipped. A cut or corrupt file
/// ends the scan early with `outcome.complete == false`.
pub fn scan(path: &Path, mut visit: impl FnMut(Item<'_>) -> Result<()>) -> Result<Scan> {
    let file = resolve(path);
    let mut undecodable = 0;
    let outcome = read_recording::<anyhow::Error>(&file, |m| {
        if m.message_encoding != RAW_ENCODING {
            return Ok(());
        }
        let Some(kind) = MessageKind::from_schema_name(m.schema) else {
            return Ok(());
        };
        match decode(kind, m.data) {
            Ok(msg) => visit(Item {
                topic: m.topic,
                msg,
            }),
            Err(_) => {
                undecodable += 1;
                Ok(())
            }
        }
    })
    .with_context(|| format!("reading the recording {}", file.display()))?;
    let info = outcome
        .metadata
        .get(SESSION_METADATA)
        .map(SessionInfo::from_metadata)
        .unwrap_or_default();
    Ok(Scan {
        outcome,
        info,
        undecodable,
    })
}

/// The recorder's account of the packets it did not keep, from its metadata.
pub fn received(
    metadata: &BTreeMap<String, BTreeMap<String, String>>,
) -> Result<Option<BTreeMap<String, UnrecordedPackets>>> {
    let Some(text) = metadata
        .get(recording::RECORDER_METADATA)
        .and_then(|m| m.get(recording::EVENTS_NOT_RECORDED))
    else {
        return Ok(None);
    };
    match serde_json::from_str(text) {
        Ok(m) => Ok(Some(m)),
        Err(e) => anyhow::bail!("the recorder's account of the event packets is malformed: {e}"),
    }
}
