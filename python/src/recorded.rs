//! `waggle.read_events`: the event packets of a Waggle recording (`session.mcap`, written by
//! the `recording` crate) as one numpy array of `EVENT_DTYPE`.
//!
//! A file is first read as an intact one (`intact`: chunks decompressed on worker threads, in
//! file order, with every check the recording reader makes). At the first irregularity it is
//! read again by `recording::read_recording`, so what this accepts, checks and reports about a
//! damaged or cut file is what `waggle audit` and `waggle replay` see: damaged chunks skipped
//! and named. Either way each packet's wire bytes are turned into records where they lie
//! (`wire_records`) and appended to one buffer that numpy then owns, with the GIL released: no
//! packet struct, no per-event Python object, no copy into numpy.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use mcap::records::{Record, op};
use numpy::PyArray1;
use proto::{Key, ObserverId};
use pyo3::prelude::*;
use recording::{
    EVENTS_NOT_RECORDED, MessageKind, RECORDER_METADATA, ReadError, ReadOutcome, SESSION_METADATA,
    SessionInfo,
};

use crate::errors::{WaggleError, bad_arg};
use crate::events::event_dtype;
use crate::intact;
use crate::wire_records::{Record as EventRecord, append_records};

/// Why a recording's events could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ReadEventsError {
    /// The file could not be opened or read.
    #[error("{path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("path: {path} is not an MCAP file: {reason}")]
    NotMcap { path: String, reason: String },
    #[error(
        "path: {path} is damaged or cut short ({problem}); read_events(..., partial=True) \
         returns the {events} events of its intact chunks"
    )]
    Damaged {
        path: String,
        problem: String,
        events: usize,
    },
    #[error("path: {path}: the packet on {topic} at {log_time_ns} ns does not decode: {reason}")]
    BadPacket {
        path: String,
        topic: String,
        log_time_ns: u64,
        reason: String,
    },
    #[error("observer: {path} holds no event packets of {wanted}{}", have_list(.have))]
    NoPackets {
        path: String,
        /// The observer asked for, or "any observer".
        wanted: String,
        /// The observers it holds packets of.
        have: Vec<String>,
    },
    #[error(
        "observer: {path} keeps the camera input of {wanted}, not the event packets (a noisy \
         sensor recorded with --record-events auto or input); `waggle replay` regenerates them, \
         `waggle run --record-events packets` records them"
    )]
    InputOnly {
        path: String,
        /// The observer asked for, or "every observer".
        wanted: String,
    },
}

/// Metadata records by name.
type Metadata = BTreeMap<String, BTreeMap<String, String>>;

fn have_list(have: &[String]) -> String {
    if have.is_empty() {
        String::new()
    } else {
        format!(" (it holds those of {})", have.join(", "))
    }
}

impl From<ReadError> for ReadEventsError {
    fn from(e: ReadError) -> Self {
        match e {
            ReadError::Io { path, source } => Self::Io { path, source },
            ReadError::NotMcap { path, reason } => Self::NotMcap { path, reason },
        }
    }
}

impl From<ReadEventsError> for PyErr {
    fn from(e: ReadEventsError) -> Self {
        match e {
            // `OSError(errno, strerror, filename)` becomes `FileNotFoundError`,
            // `PermissionError`, … as Python's own `open` raises them, with `filename` set.
            ReadEventsError::Io { path, source } => match source.raw_os_error() {
                Some(errno) => {
                    pyo3::exceptions::PyOSError::new_err((errno, source.to_string(), path))
                }
                None => pyo3::exceptions::PyOSError::new_err(format!("{path}: {source}")),
            },
            other => WaggleError::new_err(other.to_string()),
        }
    }
}

/// What was read: the records, and how the file ended.
#[derive(Debug, Default)]
pub struct ReadEvents {
    /// `EVENT_DTYPE` records, packet after packet in file order.
    pub records: Vec<EventRecord>,
    pub packets: u64,
    /// `None` for an intact file; else every problem the reader found.
    pub problem: Option<String>,
}

impl ReadEvents {
    pub fn events(&self) -> usize {
        self.records.len()
    }
}

/// The observer whose events a raw channel carries (`/sensor/O2/events` → `O2`), when its
/// schema is the event packet's.
fn events_observer(topic: &str, schema: &str) -> Option<ObserverId> {
    if schema != MessageKind::EventPacket.schema_name() {
        return None;
    }
    match Key::parse_rest(topic.strip_prefix('/')?)? {
        Key::SensorEvents(o) => Some(o),
        _ => None,
    }
}

/// One pass over a recording: the packets of the observer wanted, and which observers have
/// packets at all.
struct Pass<'a> {
    shown: &'a str,
    observer: Option<&'a ObserverId>,
    read: ReadEvents,
    have: Vec<String>,
}

impl<'a> Pass<'a> {
    fn new(shown: &'a str, observer: Option<&'a ObserverId>) -> Self {
        Self {
            shown,
            observer,
            read: ReadEvents::default(),
            have: Vec::new(),
        }
    }

    /// A channel of event packets of `o` (declared, or its first message seen): true when its
    /// packets are wanted.
    fn channel(&mut self, o: &ObserverId) -> bool {
        if !self.have.iter().any(|h| h == o.as_str()) {
            self.have.push(o.as_str().to_owned());
        }
        self.observer.is_none_or(|want| want == o)
    }

    /// A wanted packet's wire bytes.
    fn packet(
        &mut self,
        topic: &str,
        log_time_ns: u64,
        data: &[u8],
    ) -> Result<(), ReadEventsError> {
        append_records(data, &mut self.read.records).map_err(|e| ReadEventsError::BadPacket {
            path: self.shown.to_owned(),
            topic: topic.to_owned(),
            log_time_ns,
            reason: e.to_string(),
        })?;
        self.read.packets += 1;
        Ok(())
    }

    /// The result, or why there is none; `metadata` tells a recording of the cameras' input.
    fn finish(mut self, metadata: &Metadata) -> Result<ReadEvents, ReadEventsError> {
        let found = match self.observer {
            Some(o) => self.have.iter().any(|h| h == o.as_str()),
            None => !self.have.is_empty(),
        };
        if !found {
            let path = self.shown.to_owned();
            let wanted = |none| self.observer.map_or(none, ObserverId::as_str).to_owned();
            let from_input = metadata
                .get(SESSION_METADATA)
                .is_some_and(|m| SessionInfo::from_metadata(m).events_from_input);
            // `{"O1": {"packets": …}, …}`: the cameras whose packets the recorder received.
            let kept_input = metadata
                .get(RECORDER_METADATA)
                .and_then(|m| m.get(EVENTS_NOT_RECORDED))
                .is_some_and(|json| {
                    self.observer
                        .is_none_or(|o| json.contains(&format!("\"{o}\"")))
                });
            return Err(if from_input && kept_input {
                ReadEventsError::InputOnly {
                    path,
                    wanted: wanted("every observer"),
                }
            } else {
                let wanted = wanted("any observer");
                self.have.sort();
                ReadEventsError::NoPackets {
                    path,
                    wanted,
                    have: self.have,
                }
            });
        }
        // The buffer grew by doubling; numpy keeps it whole, so give back the slack.
        self.read.records.shrink_to_fit();
        Ok(self.read)
    }
}

/// The pass over an intact recording (`intact`), with what its metadata records say; `None`
/// at the first irregularity, for the tolerant reader to read the file again.
fn read_fast<'a>(
    path: &Path,
    mut pass: Pass<'a>,
) -> Result<Option<(Pass<'a>, Metadata)>, ReadEventsError> {
    let mut schemas: BTreeMap<u16, String> = BTreeMap::new();
    // Channel id → its topic, and whether its packets are wanted (`None`: not event packets).
    let mut channels: BTreeMap<u16, (String, Option<bool>)> = BTreeMap::new();
    let mut metadata = Metadata::new();
    let mut regular = true;
    let read = intact::read_intact(path, |opcode, body| {
        if opcode == op::MESSAGE {
            // channel id, sequence, log time, publish time, then the message.
            let (Some(head), Some(data)) = (body.get(..22), body.get(22..)) else {
                regular = false;
                return Ok(());
            };
            let channel = u16::from_le_bytes([head[0], head[1]]);
            // A message of an undeclared channel is skipped, as the tolerant reader does.
            if let Some((topic, Some(true))) = channels.get(&channel) {
                let log_time_ns = u64::from_le_bytes(std::array::from_fn(|i| head[6 + i]));
                pass.packet(topic, log_time_ns, data)?;
            }
            return Ok(());
        }
        if !matches!(opcode, op::CHANNEL | op::SCHEMA | op::METADATA) {
            return Ok(());
        }
        match mcap::parse_record(opcode, body) {
            Ok(Record::Channel(c)) => {
                let schema = schemas.get(&c.schema_id).map_or("", String::as_str);
                let wanted = events_observer(&c.topic, schema).map(|o| pass.channel(&o));
                channels.insert(c.id, (c.topic, wanted));
            }
            Ok(Record::Schema { header, .. }) => {
                schemas.insert(header.id, header.name);
            }
            Ok(Record::Metadata(m)) => {
                metadata.insert(m.name, m.metadata);
            }
            _ => regular = false,
        }
        Ok(())
    });
    match read {
        Ok(intact::Read::Intact) if regular => Ok(Some((pass, metadata))),
        Ok(_) => Ok(None),
        Err(intact::Stop::Io(source)) => Err(ReadEventsError::Io {
            path: pass.shown.to_owned(),
            source,
        }),
        Err(intact::Stop::Visit(e)) => Err(e),
    }
}

/// The pass by `recording::read_recording`, which skips damaged chunks and says what it lost.
fn read_tolerant<'a>(
    path: &Path,
    mut pass: Pass<'a>,
) -> Result<(Pass<'a>, ReadOutcome), ReadEventsError> {
    // Topics are few; the last one seen answers nearly every message of a busy stream.
    let mut last: Option<(String, Option<bool>)> = None;
    let outcome = recording::read_recording::<ReadEventsError>(path, |m| {
        if last.as_ref().is_none_or(|(topic, _)| topic != m.topic) {
            let wanted = events_observer(m.topic, m.schema).map(|o| pass.channel(&o));
            last = Some((m.topic.to_owned(), wanted));
        }
        match &last {
            Some((_, Some(true))) => pass.packet(m.topic, m.log_time_ns, m.data),
            _ => Ok(()),
        }
    })?;
    Ok((pass, outcome))
}

/// Reads the event packets of `observer` (`None`: of every observer) from the recording at
/// `path`, in file order. A damaged or cut file is an error unless `partial`, when the events
/// of its intact chunks are returned with the problem named.
pub fn read_events_from(
    path: &Path,
    observer: Option<&ObserverId>,
    partial: bool,
) -> Result<ReadEvents, ReadEventsError> {
    let shown = path.display().to_string();
    if let Some((pass, metadata)) = read_fast(path, Pass::new(&shown, observer))? {
        return pass.finish(&metadata);
    }
    let (pass, outcome) = read_tolerant(path, Pass::new(&shown, observer))?;
    if outcome.complete {
        return pass.finish(&outcome.metadata);
    }
    let problem = outcome.problem.unwrap_or_else(|| "incomplete".to_owned());
    if !partial {
        return Err(ReadEventsError::Damaged {
            path: shown.clone(),
            problem,
            events: pass.read.events(),
        });
    }
    let mut read = pass.finish(&outcome.metadata)?;
    read.problem = Some(problem);
    Ok(read)
}

/// The event packets of one observer (or of every observer) of a Waggle recording, as one
/// array of `EVENT_DTYPE`.
///
/// `read_events(path, observer=None, *, partial=False)`: `path` is a `session.mcap` (str or
/// path-like); `observer` is `"O2"`, or `None` for every observer's packets together. The
/// events come packet after packet in the order the recording holds them, each packet's in its
/// own order. A missing or unreadable file raises `OSError` (`FileNotFoundError`, …) naming it;
/// a file that is not a recording, an observer without packets, a packet that does not decode
/// raise `WaggleError`. A damaged or cut recording raises `WaggleError` too, unless `partial`:
/// then the events of every intact chunk are returned and a `RuntimeWarning` names what was
/// lost.
#[pyfunction]
#[pyo3(signature = (path, observer = None, *, partial = false))]
pub fn read_events<'py>(
    py: Python<'py>,
    path: PathBuf,
    observer: Option<&str>,
    partial: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let observer = observer
        .map(|o| ObserverId::new(o).map_err(|e| bad_arg("observer", e)))
        .transpose()?;
    let read = py.detach(|| read_events_from(&path, observer.as_ref(), partial))?;
    if let Some(problem) = &read.problem {
        let message = format!(
            "{}: read partially ({} events of {} packets): {problem}",
            path.display(),
            read.events(),
            read.packets
        );
        let message = std::ffi::CString::new(message.replace('\0', " "))
            .unwrap_or_else(|_| c"read partially".to_owned());
        let category = py.get_type::<pyo3::exceptions::PyRuntimeWarning>();
        PyErr::warn(py, &category, &message, 1)?;
    }
    let bytes = PyArray1::from_vec(py, read.records.into_flattened());
    bytes.call_method1("view", (event_dtype(py)?,))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(read_events, m)?)
}

#[cfg(test)]
mod tests {
    use std::io::Cursor;

    use proto::{ClockTick, EventPacket, Keys, Polarity, TICK_NS};
    use recording::{RecorderOptions, SessionWriter};

    use super::*;
    use crate::events::records_from_packet;

    fn packet(tick: u64, n: usize, salt: usize) -> EventPacket {
        let events: Vec<_> = (0..n)
            .map(|i| {
                let p = if (i + salt).is_multiple_of(3) {
                    Polarity::On
                } else {
                    Polarity::Off
                };
                let dt = (i * 40_000_000 / n.max(1)) as u32 + 1;
                (((i * 7 + salt) % 640) as u16, ((i * 3) % 480) as u16, dt, p)
            })
            .collect();
        let interval = ((tick - 1) * TICK_NS, tick * TICK_NS);
        EventPacket::from_events(tick - 1, interval, (640, 480), &events)
    }

    /// A recording of two event cameras over `ticks` ticks (small chunks, event views on), and
    /// the records each observer's packets hold.
    fn recording(ticks: u64) -> (Vec<u8>, [Vec<u8>; 2]) {
        let keys = Keys::new("t").unwrap();
        let info = SessionInfo {
            session: "t".into(),
            observers: 2,
            modality: Some("events".into()),
            ..SessionInfo::default()
        };
        let options = RecorderOptions {
            chunk_bytes: 64 << 10,
            event_view_period_ns: Some(200_000_000),
            ..RecorderOptions::default()
        };
        let mut w = SessionWriter::new(Cursor::new(Vec::new()), &info, options).unwrap();
        let mut want = [Vec::new(), Vec::new()];
        for k in 1..=ticks {
            w.record(&keys.clock(), &proto::encode(&ClockTick::at(k).unwrap()))
                .unwrap();
            for (i, want) in want.iter_mut().enumerate() {
                let p = packet(k, if k % 5 == 0 { 0 } else { 300 + 50 * i }, i);
                want.extend(records_from_packet(&p));
                let o = ObserverId::from_index(i);
                w.record(&keys.sensor_events(&o), &proto::encode(&p))
                    .unwrap();
            }
        }
        (w.finish(Default::default()).unwrap().into_inner(), want)
    }

    fn temp(name: &str, bytes: &[u8]) -> PathBuf {
        let path =
            std::env::temp_dir().join(format!("waggle-py-{}-{name}.mcap", std::process::id()));
        std::fs::write(&path, bytes).unwrap();
        path
    }

    fn flat(read: &ReadEvents) -> Vec<u8> {
        read.records.as_flattened().to_vec()
    }

    #[test]
    fn an_intact_recording_is_read_by_the_fast_pass_as_the_tolerant_reader_reads_it() {
        let (bytes, want) = recording(120);
        let path = temp("intact", &bytes);
        let (o1, o2) = (
            ObserverId::new("O1").unwrap(),
            ObserverId::new("O2").unwrap(),
        );
        for (observer, want) in [(Some(&o1), want[0].clone()), (Some(&o2), want[1].clone())] {
            let fast = read_fast(&path, Pass::new("x", observer)).unwrap();
            let (fast, _) = fast.expect("an intact file passes every check");
            let (slow, outcome) = read_tolerant(&path, Pass::new("x", observer)).unwrap();
            assert!(outcome.complete);
            assert_eq!(flat(&fast.read), want);
            assert_eq!(flat(&slow.read), want);
            assert_eq!(fast.read.packets, 120);
        }
        let all = read_events_from(&path, None, false).unwrap();
        assert_eq!(all.packets, 240);
        assert_eq!(all.events(), (want[0].len() + want[1].len()) / 13);
        let _ = std::fs::remove_file(&path);
    }

    #[test]
    fn a_damaged_or_cut_recording_is_left_to_the_tolerant_reader_and_never_panics() {
        let (bytes, _) = recording(150);
        let o1 = ObserverId::new("O1").unwrap();
        let intact = temp("whole", &bytes);
        let whole = flat(&read_events_from(&intact, Some(&o1), false).unwrap());
        let mut variants: Vec<Vec<u8>> =
            [9, 100, bytes.len() / 3, bytes.len() - 9, bytes.len() - 1]
                .iter()
                .map(|&cut| bytes[..cut].to_vec())
                .collect();
        for at in [bytes.len() / 4, bytes.len() / 2, bytes.len() - 30] {
            let mut bad = bytes.clone();
            bad[at] ^= 0x40;
            variants.push(bad);
        }
        variants.push([bytes.as_slice(), b"x"].concat());
        for (k, bad) in variants.iter().enumerate() {
            let path = temp(&format!("bad{k}"), bad);
            let fast = read_fast(&path, Pass::new("x", Some(&o1))).unwrap();
            assert!(fast.is_none(), "variant {k} passed as intact");
            match read_events_from(&path, Some(&o1), false) {
                Err(ReadEventsError::Damaged { .. } | ReadEventsError::NotMcap { .. }) => {}
                other => panic!("variant {k}: {other:?}"),
            }
            if let Ok(part) = read_events_from(&path, Some(&o1), true) {
                assert!(part.problem.is_some(), "variant {k}");
                // Only whole chunks are lost, in one stretch: the rest is as recorded.
                let part = flat(&part);
                let head = part.iter().zip(&whole).take_while(|(a, b)| a == b).count();
                let head = head - head % 13;
                assert!(part.len() <= whole.len(), "variant {k}");
                assert_eq!(
                    part[head..],
                    whole[whole.len() - (part.len() - head)..],
                    "variant {k}"
                );
            }
            let _ = std::fs::remove_file(&path);
        }
        let _ = std::fs::remove_file(&intact);
    }

    #[test]
    fn a_recording_of_the_cameras_input_says_so_and_unknown_observers_are_named() {
        let keys = Keys::new("i").unwrap();
        let o1 = ObserverId::new("O1").unwrap();
        let info = SessionInfo {
            session: "i".into(),
            observers: 1,
            modality: Some("events".into()),
            events_from_input: true,
            ..SessionInfo::default()
        };
        let options = RecorderOptions {
            events_from_input: true,
            ..RecorderOptions::default()
        };
        let mut w = SessionWriter::new(Cursor::new(Vec::new()), &info, options).unwrap();
        for k in 1..=5 {
            w.record(&keys.sensor_events(&o1), &proto::encode(&packet(k, 10, 0)))
                .unwrap();
        }
        let path = temp("input", &w.finish(Default::default()).unwrap().into_inner());
        for observer in [Some(&o1), None] {
            let err = read_events_from(&path, observer, false).unwrap_err();
            assert!(matches!(err, ReadEventsError::InputOnly { .. }), "{err}");
            assert!(err.to_string().contains("--record-events packets"), "{err}");
        }
        let o9 = ObserverId::new("O9").unwrap();
        let err = read_events_from(&path, Some(&o9), false).unwrap_err();
        assert!(matches!(err, ReadEventsError::NoPackets { .. }), "{err}");
        let _ = std::fs::remove_file(&path);

        let (bytes, _) = recording(3);
        let path = temp("two", &bytes);
        let err = read_events_from(&path, Some(&o9), false).unwrap_err();
        assert_eq!(
            err.to_string(),
            format!(
                "observer: {} holds no event packets of O9 (it holds those of O1, O2)",
                path.display()
            )
        );
        let _ = std::fs::remove_file(&path);
    }
}
