//! Per-trial record files, `<point>/trials/NNNNNN.json`: the outcome of one seeded trial (a link
//! trial, [`TrialRecord`], or any other [`Recordable`]) with the point and index it belongs to,
//! the binary, host and renderer that made it ([`Provenance`]) and a SHA-256 of all that. The lab
//! writes one per finished trial and reads them back when a study or `waggle trials` resumes
//! and when shards merge; this module owns their layout, their encoding and every check of a
//! record's bytes ([`encode`], [`decode`], [`check`]), with no file system.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::link_out::TokenOut;
use sha2::{Digest, Sha256};

/// The format tag of a record file.
pub const RECORD_FORMAT: &str = "waggle-trial-1";

/// Which binary on which host made a record, with which renderer. MuJoCo's renderer is
/// llvmpipe on the CPU, whose results may depend on Mesa's version and the CPU's instruction
/// set; Waggle's renderer is named by its identifier, whose bytes depend on neither; the version
/// decides everything else.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Provenance {
    /// The package version and the first 16 hex digits of the executable's SHA-256.
    pub version: String,
    /// `model name` from /proc/cpuinfo.
    pub cpu: String,
    /// The cameras' renderer: Waggle's (`waggle-raster/N`), or MuJoCo's render path on EGL
    /// through Mesa (its package version and any driver override).
    pub renderer: String,
}

/// A trial's outcome as a record holds it: a link trial ([`TrialRecord`]) or a whole mission
/// (the lab's baselines).
pub trait Recordable: Serialize + serde::de::DeserializeOwned + Clone {
    /// Its index in the run.
    fn record_index(&self) -> u64;
}

/// How closely a drone followed its reference over a flight (true position against the
/// reference, every physics step).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct Tracking {
    pub rms_m: f64,
    pub max_m: f64,
}

/// How one observer's token stamps compare with the ideal receiver's on the same flight.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct TokenTiming {
    /// Ideal tokens matched by a token of the same kind within ±1 s.
    pub matched: usize,
    /// Ideal tokens without a match.
    pub missed: usize,
    /// Tokens that matched no ideal token.
    pub extra: usize,
    pub mean_abs_error_ms: Option<f64>,
    pub max_abs_error_ms: Option<f64>,
    /// The ideal tokens without a match, in order: which symbols this observer lost.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub missed_at: Vec<TokenOut>,
    /// The tokens that matched no ideal token, in order: what it read instead.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub extra_at: Vec<TokenOut>,
}

/// One observer in one trial.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct ObserverTrial {
    /// Released payloads, six-bit strings, in release order.
    pub released: Vec<String>,
    pub success: bool,
    /// Per released frame: when its final NULL was confirmed (plus any link delay), sim s.
    pub release_s: Vec<f64>,
    pub tokens: usize,
    pub token_timing: TokenTiming,
    /// Per released frame: its release (final NULL confirmed, plus any link delay) after the
    /// start of that offer's final NULL in the schedule, s.
    pub latency_s: Vec<f64>,
    /// Per released frame: its release after the ideal receiver's release of the same offer, s
    /// (`null` when the ideal receiver did not release it).
    pub vs_ideal_s: Vec<Option<f64>>,
    /// Sensor messages (frames or packets) the camera produced, and how many the link lost.
    pub messages: u64,
    pub messages_lost: u64,
    /// Event cameras: events the receiver got, and how many its noise front end removed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub events_received: Option<u64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub events_removed: Option<u64>,
    /// Of the events the noise front end kept, how many the ego-motion front end removed
    /// (absent while the observer's airframe never turned).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub events_removed_ego: Option<u64>,
}

/// One trial.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct TrialRecord {
    pub index: u64,
    pub seed: u64,
    /// Every observer succeeded and, on a trial's own flight, no drone touched another.
    pub success: bool,
    pub observers: BTreeMap<String, ObserverTrial>,
    /// A trial that flew its own flight (wind, cascade, gusts, placement): how it flew.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flight: Option<TrialFlight>,
    /// A plug-in receiver that failed this trial (raised, returned malformed output, died or
    /// ran past the time limit): then no observer's result counts.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plugin_failure: Option<PluginFailure>,
}

impl Recordable for TrialRecord {
    fn record_index(&self) -> u64 {
        self.index
    }
}

/// How a plug-in receiver failed a trial.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct PluginFailure {
    /// `failed`, or `timed-out` (a wall clock decided it: the run is not reproducible).
    pub outcome: String,
    pub reason: String,
}

/// How a trial's own flight went.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct TrialFlight {
    /// The performer against its reference, every physics step.
    pub performer_tracking: Tracking,
    /// Physics steps with a contact between drones (any fails the trial).
    pub contact_steps: u64,
}

/// What a record file's checksum covers.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Body<R> {
    pub format: String,
    pub point: String,
    pub index: u64,
    pub provenance: Provenance,
    pub record: R,
}

/// A record file: its body and the body's SHA-256.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct StoredTrial<R> {
    pub body: Body<R>,
    pub sha256: String,
}

/// Why a record's bytes are not trial `index` of a point; the texts are those the lab reports
/// beside a damaged record's path.
#[derive(Debug, thiserror::Error)]
pub enum TrialRecordError {
    /// Not JSON of a record's shape (serde names the field at fault).
    #[error("not a trial record: {0}")]
    NotARecord(serde_json::Error),
    /// The body could not be encoded again to check its digest.
    #[error("{0}")]
    Encode(serde_json::Error),
    #[error("checksum mismatch (recorded {recorded}, content {content})")]
    Checksum { recorded: String, content: String },
    #[error(
        "holds trial {index} of {point:?} (format {format}), not trial {expected_index} of {expected_point:?}"
    )]
    Elsewhere {
        index: u64,
        point: String,
        format: String,
        expected_index: u64,
        expected_point: String,
    },
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// The SHA-256 (hex) of `body`'s compact JSON.
pub fn checksum<R: Serialize>(body: &Body<R>) -> Result<String, serde_json::Error> {
    Ok(hex(&Sha256::digest(serde_json::to_vec(body)?)))
}

/// The bytes of the record file of trial `record` of point `point`, made by `provenance`.
pub fn encode<R: Recordable>(
    point: &str,
    provenance: Provenance,
    record: &R,
) -> Result<Vec<u8>, serde_json::Error> {
    let body = Body {
        format: RECORD_FORMAT.into(),
        point: point.into(),
        index: record.record_index(),
        provenance,
        record: record.clone(),
    };
    let stored = StoredTrial {
        sha256: checksum(&body)?,
        body,
    };
    serde_json::to_vec(&stored)
}

/// A record file's bytes, parsed but not checked.
pub fn decode<R: Recordable>(bytes: &[u8]) -> Result<StoredTrial<R>, TrialRecordError> {
    serde_json::from_slice(bytes).map_err(TrialRecordError::NotARecord)
}

/// Checks a parsed record against its digest and against the point and index its file name
/// gives: the record and the provenance, or why the file is damaged.
pub fn check<R: Recordable>(
    stored: StoredTrial<R>,
    point: &str,
    index: u64,
) -> Result<(R, Provenance), TrialRecordError> {
    let sum = checksum(&stored.body).map_err(TrialRecordError::Encode)?;
    if sum != stored.sha256 {
        return Err(TrialRecordError::Checksum {
            recorded: stored.sha256,
            content: sum,
        });
    }
    let b = stored.body;
    if b.format != RECORD_FORMAT
        || b.point != point
        || b.index != index
        || b.record.record_index() != index
    {
        return Err(TrialRecordError::Elsewhere {
            index: b.index,
            point: b.point,
            format: b.format,
            expected_index: index,
            expected_point: point.to_owned(),
        });
    }
    Ok((b.record, b.provenance))
}

/// [`decode`], then [`check`]: trial `index` of `point` from its record file's bytes.
pub fn parse<R: Recordable>(
    bytes: &[u8],
    point: &str,
    index: u64,
) -> Result<(R, Provenance), TrialRecordError> {
    check(decode(bytes)?, point, index)
}
