//! Session recordings (`DIR/session.mcap`, written by `recorder-node`): what the launcher gives
//! the recorder, and reading a recording's raw Waggle messages back for `waggle replay` and
//! `waggle audit`.

use std::path::{Path, PathBuf};
use std::process::Child;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use recording::{
    Decoded, MessageKind, RAW_ENCODING, ReadOutcome, SESSION_METADATA, SessionInfo, decode,
    read_recording,
};

use crate::case::{BUILT_IN, Case};

/// File name of the recording inside a run directory.
pub const RECORDING_FILE: &str = "session.mcap";

/// The TOML text of a case given by name or path (what `Case::load` parsed).
pub fn case_source(name_or_path: &str) -> Result<String> {
    match BUILT_IN.iter().find(|(n, _)| *n == name_or_path) {
        Some((_, text)) => Ok((*text).to_string()),
        None => std::fs::read_to_string(name_or_path)
            .with_context(|| format!("reading case file {name_or_path}")),
    }
}

/// `recorder-node` arguments for a run writing `out_dir/session.mcap`; writes the case text
/// to `out_dir/case.toml` so the recording holds the case and its expected outcome.
pub fn recorder_args(
    case_arg: &str,
    case: &Case,
    modality: &str,
    out_dir: &Path,
) -> Result<Vec<String>> {
    let case_file = out_dir.join("case.toml");
    std::fs::write(&case_file, case_source(case_arg)?)
        .with_context(|| format!("writing {}", case_file.display()))?;
    Ok(vec![
        "--out".into(),
        out_dir.join(RECORDING_FILE).display().to_string(),
        "--case-name".into(),
        case.name.clone(),
        "--case-file".into(),
        case_file.display().to_string(),
        "--modality".into(),
        modality.to_string(),
    ])
}

/// Sends SIGTERM and waits up to `timeout` for the child to exit; true if it did.
pub fn terminate(child: &mut Child, timeout: Duration) -> bool {
    let Ok(pid) = libc::pid_t::try_from(child.id()) else {
        return false;
    };
    // SAFETY: kill(2) with a pid we spawned and still own (not yet reaped) and a valid signal.
    if unsafe { libc::kill(pid, libc::SIGTERM) } != 0 {
        return false;
    }
    let until = Instant::now() + timeout;
    while Instant::now() < until {
        if let Ok(Some(_)) = child.try_wait() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    false
}

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
