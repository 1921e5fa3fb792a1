//! The performer's home as the rests of one reception window place it.
//!
//! Every symbol starts and ends at the performer's home, so every confirmed rest of a reception
//! window is a reading of one point. A receiver that holds its last estimate through a rest
//! (an event camera sees nothing of a still target) places a rest where the target was last
//! *seen*: under heavy sensor noise the slow last centimetres into home are filtered out, and
//! that reading can fall 7–14 px short while the window's other rests agree within ≈ 2 px
//! (measured, `docs/decisions/v2e-sensor-model.md`, the `v2e-noisy` edge). The component-wise
//! median of the window's rests is a reading of home that one short rest cannot move.
//!
//! A window's first symbols come before it has rests enough for a median: a path rejected only
//! for its open ends then *waits* for the next confirmed rest, which pools a home, and is read
//! there. Its NULL is not held back (a delimiter must never wait on a later rest): the reading
//! is emitted late, flagged so, and the frame parser puts it back between the two NULLs it
//! belongs between ([`crate::FrameParser::push_late`]). The event receiver's START, whose
//! start is the rest after the acquisition sweep, is such a symbol
//! (`docs/decisions/event-link-in-wind.md`).

use std::collections::VecDeque;

use crate::{Classification, MatchSettings, Rejection, classify};

/// A symbol's reading: accepted, or why not.
pub(crate) type Reading = Result<Classification, Rejection>;

/// Rests that vote, the latest first out of the window when it is full: a home that drifts
/// (an observer in wind) is followed, not averaged over the whole reception.
const MAX_RESTS: usize = 8;

/// Fewest rests for a median that one outlier cannot decide.
const MIN_RESTS: usize = 3;

/// The window's confirmed rest positions (image pixels) and the reading waiting for a home.
#[derive(Debug, Clone, Default)]
pub(crate) struct RestHome {
    rests_px: VecDeque<[f64; 2]>,
    waiting: Option<Waiting>,
}

/// A path rejected only for its open ends before the window had a home.
#[derive(Debug, Clone)]
struct Waiting {
    candidate: Vec<[f64; 2]>,
    reading: Reading,
    stamp_ns: u64,
}

impl RestHome {
    /// A confirmed rest at `point_px`.
    pub(crate) fn record(&mut self, point_px: [f64; 2]) {
        if self.rests_px.len() == MAX_RESTS {
            self.rests_px.pop_front();
        }
        self.rests_px.push_back(point_px);
    }

    /// The component-wise median of the recorded rests, once there are enough of them.
    pub(crate) fn centre_px(&self) -> Option<[f64; 2]> {
        if self.rests_px.len() < MIN_RESTS {
            return None;
        }
        let median = |axis: usize| {
            let mut v: Vec<f64> = self.rests_px.iter().map(|p| p[axis]).collect();
            v.sort_by(f64::total_cmp);
            let n = v.len();
            if n % 2 == 1 {
                v[n / 2]
            } else {
                0.5 * (v[n / 2 - 1] + v[n / 2])
            }
        };
        Some([median(0), median(1)])
    }

    /// `candidate` with both ends at the home, when there is one and both ends lie within
    /// `radius_px` of it (a rest farther off is not a reading of home).
    pub(crate) fn homed(&self, candidate: &[[f64; 2]], radius_px: f64) -> Option<Vec<[f64; 2]>> {
        let home = self.centre_px()?;
        let (&first, &last) = (candidate.first()?, candidate.last()?);
        let near =
            |p: [f64; 2]| ((p[0] - home[0]).powi(2) + (p[1] - home[1]).powi(2)).sqrt() <= radius_px;
        if candidate.len() < 2 || !near(first) || !near(last) {
            return None;
        }
        let mut homed = candidate.to_vec();
        homed[0] = home;
        homed[candidate.len() - 1] = home;
        Some(homed)
    }

    /// The reading of `candidate` (first read as `reading`, at `stamp_ns`) to emit now, or
    /// `None` when it waits for a home. Only a path rejected only for its open ends is read
    /// again, with both ends at the home within `reach_px` (`None`: no pooling, `reading` as is).
    pub(crate) fn read(
        &mut self,
        candidate: Vec<[f64; 2]>,
        reading: Reading,
        stamp_ns: u64,
        reach_px: Option<f64>,
        settings: &MatchSettings,
    ) -> Option<Reading> {
        let (Err(Rejection::NotClosed { .. }), Some(reach_px)) = (&reading, reach_px) else {
            return Some(reading);
        };
        if self.centre_px().is_none() {
            self.waiting = Some(Waiting {
                candidate,
                reading,
                stamp_ns,
            });
            return None;
        }
        Some(self.at_home(&candidate, reading, reach_px, settings))
    }

    /// The waiting reading, read at the home the rests now pool (as it was without one), and
    /// its stamp; call after recording a rest.
    pub(crate) fn take_waiting(
        &mut self,
        reach_px: Option<f64>,
        settings: &MatchSettings,
    ) -> Option<(Reading, u64)> {
        let w = self.waiting.take()?;
        let reading = match reach_px {
            Some(reach_px) => self.at_home(&w.candidate, w.reading, reach_px, settings),
            None => w.reading,
        };
        Some((reading, w.stamp_ns))
    }

    /// Forgets the waiting reading (continuity broke: the interruption's `Unknown` discards
    /// its frame either way).
    pub(crate) fn drop_waiting(&mut self) {
        self.waiting = None;
    }

    fn at_home(
        &self,
        candidate: &[[f64; 2]],
        reading: Reading,
        reach_px: f64,
        settings: &MatchSettings,
    ) -> Reading {
        match self.homed(candidate, reach_px) {
            Some(homed) => better(reading, classify(&homed, settings)),
            None => reading,
        }
    }
}

/// The better of two readings of one symbol: an accepted one over a rejection, the closer
/// match of two accepted ones (ties to `a`).
pub(crate) fn better(a: Reading, b: Reading) -> Reading {
    match (&a, &b) {
        (Err(_), Ok(_)) => b,
        (Ok(x), Ok(y)) if y.error < x.error => b,
        _ => a,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_short_rest_does_not_move_the_centre() {
        let mut home = RestHome::default();
        home.record([323.0, 240.0]);
        assert_eq!(home.centre_px(), None, "one rest is no median");
        home.record([324.0, 239.0]);
        assert_eq!(home.centre_px(), None, "two rests cannot outvote one");
        home.record([336.0, 241.0]);
        assert_eq!(home.centre_px(), Some([324.0, 240.0]));
    }

    #[test]
    fn the_oldest_rests_leave_the_window() {
        let mut home = RestHome::default();
        for _ in 0..MAX_RESTS {
            home.record([100.0, 100.0]);
        }
        for _ in 0..MAX_RESTS / 2 + 1 {
            home.record([200.0, 150.0]);
        }
        assert_eq!(home.centre_px(), Some([200.0, 150.0]));
    }
}
