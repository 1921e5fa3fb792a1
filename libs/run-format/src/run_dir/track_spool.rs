//! An observer's image-plane track kept on disk while a run lasts, written into
//! `observers.json` at its end.
//!
//! The launcher receives every observer's track samples (four a tick while it receives) and
//! `observers.json` holds them all, sorted by stamp with repeated stamps dropped. Held in
//! memory they were most of what the launcher grew by in a long session (≈ 9 MB an hour of
//! sim time for three observers); here each sample is 25 bytes appended to an unnamed file,
//! and [`SpooledRecord`] serialises exactly as [`ObserverRecord`] with the same content would,
//! reading the samples back as it writes them. Samples that arrive in stamp order (every
//! honest run) never come back into memory; once one arrives out of order the spool is read
//! back whole and sorted at the end, as the in-memory record was.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::os::unix::fs::FileExt;
use std::path::Path;
use std::sync::Mutex;

use proto::{Decision, FrameEvent, TokenEvent, TrackSample};
use serde::ser::{Error as _, SerializeSeq, SerializeStruct};
use serde::{Serialize, Serializer};

use super::ObserverRecord;

/// Bytes of one spooled sample: stamp (u64), has-position (u8), x and y (f64 bits).
const SAMPLE_BYTES: usize = 25;

/// An observer's track samples, appended to an unnamed file in a directory.
#[derive(Debug)]
pub struct TrackSpool {
    /// Created with the first sample (a run without tracks makes no file).
    file: Option<BufWriter<File>>,
    dir: std::path::PathBuf,
    /// Samples in the file.
    len: u64,
    last_stamp_ns: Option<u64>,
    /// A sample arrived with a stamp below one before it: sort at the end.
    unordered: bool,
    /// The first write that failed; the record then refuses to serialise, naming it.
    error: Option<String>,
}

impl TrackSpool {
    /// An empty spool whose file, once needed, lives (unnamed) in `dir`.
    pub fn new_in(dir: &Path) -> Self {
        Self {
            file: None,
            dir: dir.to_path_buf(),
            len: 0,
            last_stamp_ns: None,
            unordered: false,
            error: None,
        }
    }

    /// Appends `samples`. In stamp order a sample repeating the previous stamp is dropped
    /// here, as the sorted record's de-duplication would drop it (it keeps the first).
    pub fn extend(&mut self, samples: impl IntoIterator<Item = TrackSample>) {
        for s in samples {
            match self.last_stamp_ns {
                Some(last) if !self.unordered && s.stamp_ns == last => continue,
                Some(last) if s.stamp_ns < last => self.unordered = true,
                _ => {}
            }
            self.last_stamp_ns = Some(self.last_stamp_ns.map_or(s.stamp_ns, |l| l.max(s.stamp_ns)));
            self.append(&s);
        }
    }

    fn append(&mut self, s: &TrackSample) {
        if self.error.is_some() {
            return;
        }
        if self.file.is_none() {
            match tempfile::tempfile_in(&self.dir) {
                Ok(f) => self.file = Some(BufWriter::with_capacity(64 << 10, f)),
                Err(e) => {
                    let dir = self.dir.display();
                    self.error = Some(format!("creating a track spool in {dir}: {e}"));
                    return;
                }
            }
        }
        let mut bytes = [0u8; SAMPLE_BYTES];
        bytes[..8].copy_from_slice(&s.stamp_ns.to_le_bytes());
        if let Some([x, y]) = s.pos_px {
            bytes[8] = 1;
            bytes[9..17].copy_from_slice(&x.to_bits().to_le_bytes());
            bytes[17..].copy_from_slice(&y.to_bits().to_le_bytes());
        }
        let written = self.file.as_mut().map(|f| f.write_all(&bytes));
        match written {
            Some(Ok(())) => self.len += 1,
            Some(Err(e)) => self.error = Some(format!("writing the track spool: {e}")),
            None => {}
        }
    }

    /// Samples spooled so far (after in-order de-duplication).
    pub fn len(&self) -> u64 {
        self.len
    }

    /// No sample spooled.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Flushes the file and reads it from its start, by position, so the file's own offset
    /// (where the next sample goes) does not move: a spool can be read any number of times.
    fn reader(&mut self) -> Result<Option<SpoolReader>, String> {
        if let Some(e) = &self.error {
            return Err(e.clone());
        }
        let Some(w) = self.file.as_mut() else {
            return Ok(None);
        };
        w.flush()
            .map_err(|e| format!("flushing the track spool: {e}"))?;
        let file = w
            .get_ref()
            .try_clone()
            .map_err(|e| format!("opening the track spool again: {e}"))?;
        Ok(Some(SpoolReader {
            file,
            at: 0,
            buf: Vec::new(),
            used: 0,
            left: self.len,
        }))
    }
}

/// Reads spooled samples back in the order they were written, a block at a time.
struct SpoolReader {
    file: File,
    /// File offset of the next block.
    at: u64,
    buf: Vec<u8>,
    /// Bytes of `buf` already handed out.
    used: usize,
    /// Samples not yet handed out.
    left: u64,
}

/// Samples read back per block.
const BLOCK_SAMPLES: u64 = 2_048;

impl Iterator for SpoolReader {
    type Item = Result<TrackSample, String>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.left == 0 {
            return None;
        }
        if self.used == self.buf.len() {
            let n = self.left.min(BLOCK_SAMPLES) as usize * SAMPLE_BYTES;
            self.buf.resize(n, 0);
            if let Err(e) = self.file.read_exact_at(&mut self.buf, self.at) {
                self.left = 0;
                return Some(Err(format!("reading the track spool back: {e}")));
            }
            self.at += n as u64;
            self.used = 0;
        }
        self.left -= 1;
        let b = &self.buf[self.used..self.used + SAMPLE_BYTES];
        self.used += SAMPLE_BYTES;
        let word = |r: std::ops::Range<usize>| {
            let mut w = [0u8; 8];
            w.copy_from_slice(&b[r]);
            u64::from_le_bytes(w)
        };
        let pos_px =
            (b[8] == 1).then(|| [f64::from_bits(word(9..17)), f64::from_bits(word(17..25))]);
        Some(Ok(TrackSample {
            stamp_ns: word(0..8),
            pos_px,
        }))
    }
}

/// An observer's record as the launcher gathers it: tokens, frames and decisions in memory
/// (a few per symbol), the track in a [`TrackSpool`]. Serialises as [`ObserverRecord`].
#[derive(Debug)]
pub struct SpooledRecord {
    pub tokens: Vec<TokenEvent>,
    pub frames: Vec<FrameEvent>,
    pub decisions: Vec<Decision>,
    /// Behind a lock because serialising reads the file back (`serialize` takes `&self`).
    track: Mutex<TrackSpool>,
}

impl SpooledRecord {
    /// An empty record whose track spools into `dir`.
    pub fn new_in(dir: &Path) -> Self {
        Self {
            tokens: Vec::new(),
            frames: Vec::new(),
            decisions: Vec::new(),
            track: Mutex::new(TrackSpool::new_in(dir)),
        }
    }

    /// Appends track samples.
    pub fn extend_track(&mut self, samples: impl IntoIterator<Item = TrackSample>) {
        self.spool().extend(samples);
    }

    /// Track samples spooled so far.
    pub fn track_len(&mut self) -> u64 {
        self.spool().len()
    }

    fn spool(&mut self) -> &mut TrackSpool {
        self.track.get_mut().unwrap_or_else(|p| p.into_inner())
    }
}

impl From<SpooledRecord> for ObserverRecord {
    /// The whole record in memory (for tests and small runs); a spool that cannot be read
    /// back gives the samples read before the failure.
    fn from(mut r: SpooledRecord) -> Self {
        let mut track: Vec<TrackSample> = match r.spool().reader() {
            Ok(Some(rd)) => rd.map_while(Result::ok).collect(),
            _ => Vec::new(),
        };
        track.sort_by_key(|t| t.stamp_ns);
        track.dedup_by_key(|t| t.stamp_ns);
        ObserverRecord {
            tokens: r.tokens,
            frames: r.frames,
            decisions: r.decisions,
            track,
        }
    }
}

impl Serialize for SpooledRecord {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut st = serializer.serialize_struct("ObserverRecord", 4)?;
        st.serialize_field("tokens", &self.tokens)?;
        st.serialize_field("frames", &self.frames)?;
        st.serialize_field("decisions", &self.decisions)?;
        st.serialize_field("track", &TrackField(&self.track))?;
        st.end()
    }
}

/// The `track` field: the spool's samples, sorted when they did not arrive in order.
struct TrackField<'a>(&'a Mutex<TrackSpool>);

impl Serialize for TrackField<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut spool = self.0.lock().unwrap_or_else(|p| p.into_inner());
        let unordered = spool.unordered;
        let Some(reader) = spool.reader().map_err(S::Error::custom)? else {
            return serializer.serialize_seq(Some(0))?.end();
        };
        if unordered {
            let mut all = reader
                .collect::<Result<Vec<_>, _>>()
                .map_err(S::Error::custom)?;
            all.sort_by_key(|t| t.stamp_ns);
            all.dedup_by_key(|t| t.stamp_ns);
            return all.serialize(serializer);
        }
        let mut seq = serializer.serialize_seq(Some(spool.len as usize))?;
        for s in reader {
            seq.serialize_element(&s.map_err(S::Error::custom)?)?;
        }
        seq.end()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(stamp_ns: u64, pos: Option<[f64; 2]>) -> TrackSample {
        TrackSample {
            stamp_ns,
            pos_px: pos,
        }
    }

    /// The same samples as a spooled record and as an in-memory one, sorted and de-duplicated
    /// as the launcher's record always was: the same bytes of `observers.json`.
    fn same_bytes(samples: &[TrackSample]) {
        let dir = std::env::temp_dir();
        let mut spooled = SpooledRecord::new_in(&dir);
        for chunk in samples.chunks(3) {
            spooled.extend_track(chunk.iter().cloned());
        }
        let mut track = samples.to_vec();
        track.sort_by_key(|t| t.stamp_ns);
        track.dedup_by_key(|t| t.stamp_ns);
        let memory = ObserverRecord {
            track,
            ..ObserverRecord::default()
        };
        let want = serde_json::to_string_pretty(&memory).unwrap();
        assert_eq!(serde_json::to_string_pretty(&spooled).unwrap(), want);
        // Written once, the spool is handed over: the in-memory form reads the same samples.
        let mut again = SpooledRecord::new_in(&dir);
        again.extend_track(samples.iter().cloned());
        assert_eq!(ObserverRecord::from(again), memory);
    }

    #[test]
    fn a_spooled_track_writes_what_the_sorted_record_wrote() {
        same_bytes(&[]);
        let awkward = [0.1 + 0.2, -0.0, f64::MIN_POSITIVE, 1e300, 47.25];
        let in_order: Vec<_> = (0..40u64)
            .map(|i| {
                let p = (i % 4 != 0).then(|| [awkward[i as usize % 5], i as f64 / 3.0]);
                sample(1_000 * (i / 2), p)
            })
            .collect();
        same_bytes(&in_order);
        let mut shuffled = in_order.clone();
        shuffled.swap(3, 30);
        shuffled.swap(11, 12);
        shuffled.push(sample(7_000, Some([9.0, 9.0])));
        same_bytes(&shuffled);
    }

    #[test]
    fn a_spooled_record_serialises_the_same_twice() {
        let mut r = SpooledRecord::new_in(&std::env::temp_dir());
        r.extend_track((0..5).map(|i| sample(i, Some([i as f64, 1.0]))));
        let first = serde_json::to_string(&r).unwrap();
        assert_eq!(serde_json::to_string(&r).unwrap(), first);
        assert_eq!(r.track_len(), 5);
    }

    #[test]
    fn a_spool_that_cannot_be_made_names_its_directory() {
        let mut r = SpooledRecord::new_in(Path::new("/nonexistent/waggle-spool"));
        r.extend_track([sample(1, None)]);
        let err = serde_json::to_string(&r).unwrap_err().to_string();
        assert!(err.contains("/nonexistent/waggle-spool"), "{err}");
    }
}
