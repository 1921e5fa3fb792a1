//! An observer's image-plane track (`observer/<o>/track`): the estimate its receiver fed to the
//! segmenter, for the record and the report's per-symbol trajectory figures. Published by the
//! observer itself from its own perception; nothing consumes it to make a decision.

use serde::{Deserialize, Serialize};

use crate::clock::{check_finite, stamp_in_tick};
use crate::codec::Validate;
use crate::keys::ObserverId;
use crate::scene::{IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX};

/// One receiver step: where the receiver placed the target, if anywhere.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TrackSample {
    pub stamp_ns: u64,
    /// Target position in the image (x right, y down), px; `None` when the receiver has none.
    pub pos_px: Option<[f64; 2]>,
}

/// The track samples of one observer in one tick (empty while the observer is not receiving).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObserverTrack {
    pub observer: ObserverId,
    pub tick: u64,
    /// In strictly increasing stamp order, every stamp inside tick `tick`.
    pub samples: Vec<TrackSample>,
}

/// Most samples one tick may carry (the event source renders 4 times per tick).
pub const MAX_TRACK_SAMPLES_PER_TICK: usize = 16;

/// How far outside the image a track estimate may lie (a smoothed estimate can overshoot), px.
const TRACK_MARGIN_PX: f64 = 1_000.0;

impl Validate for ObserverTrack {
    fn validate(&self) -> Result<(), String> {
        if self.samples.len() > MAX_TRACK_SAMPLES_PER_TICK {
            return Err(format!(
                "track of {} carries {} samples in one tick (limit {MAX_TRACK_SAMPLES_PER_TICK})",
                self.observer,
                self.samples.len()
            ));
        }
        let mut last: Option<u64> = None;
        for s in &self.samples {
            if !stamp_in_tick(s.stamp_ns, self.tick) {
                return Err(format!(
                    "track sample at {} ns is outside tick {}",
                    s.stamp_ns, self.tick
                ));
            }
            if last.is_some_and(|l| s.stamp_ns <= l) {
                return Err(format!(
                    "track samples of {} out of order at {} ns",
                    self.observer, s.stamp_ns
                ));
            }
            last = Some(s.stamp_ns);
            if let Some(p) = s.pos_px {
                check_finite(&format!("track position of {}", self.observer), &p)?;
                let (w, h) = (f64::from(IMAGE_WIDTH_PX), f64::from(IMAGE_HEIGHT_PX));
                if !(-TRACK_MARGIN_PX..=w + TRACK_MARGIN_PX).contains(&p[0])
                    || !(-TRACK_MARGIN_PX..=h + TRACK_MARGIN_PX).contains(&p[1])
                {
                    return Err(format!(
                        "track position {p:?} of {} is far outside the image",
                        self.observer
                    ));
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{DecodeError, TICK_NS, decode, encode};

    fn track(samples: Vec<TrackSample>) -> ObserverTrack {
        ObserverTrack {
            observer: ObserverId::new("O2").unwrap(),
            tick: 10,
            samples,
        }
    }

    #[test]
    fn a_track_round_trips_exactly() {
        let t = track(vec![
            TrackSample {
                stamp_ns: 10 * TICK_NS - 1,
                pos_px: Some([320.25, 240.5]),
            },
            TrackSample {
                stamp_ns: 10 * TICK_NS,
                pos_px: None,
            },
        ]);
        let bytes = encode(&t);
        assert_eq!(decode::<ObserverTrack>(&bytes).unwrap(), t);
        let empty = track(vec![]);
        assert_eq!(decode::<ObserverTrack>(&encode(&empty)).unwrap(), empty);
    }

    #[test]
    fn inconsistent_tracks_and_trailing_bytes_are_rejected() {
        let sample = |stamp_ns, pos_px| TrackSample { stamp_ns, pos_px };
        let at = 10 * TICK_NS;
        for (bad, needle) in [
            (track(vec![sample(at + 1, None)]), "outside tick"),
            (
                track(vec![sample(at, None), sample(at, None)]),
                "out of order",
            ),
            (track(vec![sample(at, Some([f64::NAN, 1.0]))]), "finite"),
            (track(vec![sample(at, Some([1.0e6, 1.0]))]), "far outside"),
            (track(vec![sample(at, None); 17]), "limit"),
        ] {
            match decode::<ObserverTrack>(&encode(&bad)) {
                Err(DecodeError::Inconsistent(m)) => assert!(m.contains(needle), "{m}"),
                other => panic!("{needle}: {other:?}"),
            }
        }
        let mut bytes = encode(&track(vec![]));
        bytes.push(0);
        assert!(matches!(
            decode::<ObserverTrack>(&bytes),
            Err(DecodeError::Malformed(_))
        ));
    }
}
