//! A real camera's background activity laid over a simulated stream: the events of a
//! recording's background (a static stretch, or its isolated events, as [`crate::fit`] tells
//! them), replayed into a sensor of any size.
//!
//! The recording is tiled over the sensor (cropped where it is larger) and looped in time, so
//! each sensor pixel replays one recording pixel's background at its own rate, hot pixels and
//! the spread of rates across pixels included. Each copy has its own offset in time and in both
//! image axes, drawn from the seed; several copies overlaid stand for a noisier sensor of the
//! same kind (`copies` times the rate, the same spatial structure). The events are added as
//! shot noise is: they do not move a pixel's reference level and the refractory period does not
//! apply to them (the recording's own events already show its sensor's).

use std::sync::Arc;

use crate::event::Event;
use crate::fit::{Background, FitError, SensorFit, fit, isolated};

/// Most copies of a recording laid over one sensor.
pub const MAX_COPIES: u32 = 1000;

/// The background of one recording, rebased to start at 0.
#[derive(Clone, PartialEq)]
pub struct RealNoise {
    /// What the source is called in records and reports (its file name).
    pub name: String,
    /// SHA-256 of the file, hex: what a record names the source by.
    pub digest: String,
    pub width: u16,
    pub height: u16,
    /// The background's duration, ns (the loop's period).
    pub duration_ns: u64,
    /// The background's events, time-ordered, `t_ns` in `[0, duration_ns)`.
    events: Vec<Event>,
    /// The sensor model's terms fitted from the same recording and background.
    pub fitted: SensorFit,
}

impl std::fmt::Debug for RealNoise {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RealNoise")
            .field("name", &self.name)
            .field("digest", &self.digest)
            .field("size", &(self.width, self.height))
            .field("duration_ns", &self.duration_ns)
            .field("events", &self.events.len())
            .finish_non_exhaustive()
    }
}

impl RealNoise {
    /// The background of `events` (time-ordered) of a `width`×`height` recording, as
    /// `background` tells it from the signal. Refused as [`fit`] refuses.
    pub fn from_recording(
        name: &str,
        digest: &str,
        events: &[Event],
        width: u16,
        height: u16,
        background: Background,
    ) -> Result<Self, FitError> {
        let fitted = fit(events, width, height, background)?;
        let (start_ns, duration_ns, keep) = match background {
            Background::Static { start_ns, end_ns } => (
                start_ns,
                end_ns - start_ns,
                events
                    .iter()
                    .map(|e| (start_ns..end_ns).contains(&e.t_ns))
                    .collect(),
            ),
            Background::Isolated => {
                let first = events.first().map_or(0, |e| e.t_ns);
                let last = events.last().map_or(0, |e| e.t_ns);
                (first, last - first, isolated(events, width, height))
            }
        };
        let events = events
            .iter()
            .zip(keep)
            .filter(|(e, k)| *k && e.t_ns - start_ns < duration_ns)
            .map(|(e, _)| Event {
                t_ns: e.t_ns - start_ns,
                ..*e
            })
            .collect();
        Ok(Self {
            name: name.to_owned(),
            digest: digest.to_owned(),
            width,
            height,
            duration_ns,
            events,
            fitted,
        })
    }

    /// Background events kept.
    pub fn len(&self) -> usize {
        self.events.len()
    }

    pub fn is_empty(&self) -> bool {
        self.events.is_empty()
    }
}

/// One copy's offsets: recording time `t + t0_ns` (mod the duration) and recording pixel
/// `((x + dx) mod W, (y + dy) mod H)` play at sensor time `t`, pixel `(x, y)`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Offset {
    t0_ns: u64,
    dx: u16,
    dy: u16,
}

/// A recording's background replayed into one sensor from its first render on.
#[derive(Debug, Clone)]
pub struct RealNoiseTiler {
    source: Arc<RealNoise>,
    copies: Vec<Offset>,
    width: u16,
    height: u16,
    /// Events at or before this sensor time have been given out (None: not started).
    filled_ns: Option<u64>,
}

/// SplitMix64: a seed's stream of offsets, the same on every machine.
fn splitmix(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl RealNoiseTiler {
    /// `copies` (1 to [`MAX_COPIES`], clamped) of `source` over a `width`×`height` sensor, their
    /// offsets drawn from `seed`.
    pub fn new(source: Arc<RealNoise>, copies: u32, width: u16, height: u16, seed: u64) -> Self {
        let mut state = seed;
        let copies = (0..copies.clamp(1, MAX_COPIES))
            .map(|_| Offset {
                t0_ns: splitmix(&mut state) % source.duration_ns.max(1),
                dx: (splitmix(&mut state) % u64::from(source.width.max(1))) as u16,
                dy: (splitmix(&mut state) % u64::from(source.height.max(1))) as u16,
            })
            .collect();
        Self {
            source,
            copies,
            width,
            height,
            filled_ns: None,
        }
    }

    /// Starts the replay at `stamp_ns` (the first render): nothing at or before it.
    pub fn start(&mut self, stamp_ns: u64) {
        self.filled_ns.get_or_insert(stamp_ns);
    }

    /// Appends the events in `(last call's to_ns, to_ns]`, sorted by time, then pixel, then
    /// polarity (an empty recording, or a call before [`Self::start`], adds none).
    pub fn fill(&mut self, to_ns: u64, out: &mut Vec<Event>) {
        let Some(from_ns) = self.filled_ns else {
            return;
        };
        if to_ns <= from_ns {
            return;
        }
        self.filled_ns = Some(to_ns);
        let period = self.source.duration_ns;
        if period == 0 || self.source.events.is_empty() {
            return;
        }
        let start = out.len();
        for copy in &self.copies {
            // Recording-clock instants u = t + t0 for sensor t in (from, to].
            let (first_u, last_u) = (from_ns + 1 + copy.t0_ns, to_ns + copy.t0_ns);
            for lap in first_u / period..=last_u / period {
                let base = lap * period;
                let lo = first_u.max(base) - base;
                let hi = last_u.min(base + period - 1) - base;
                let events = &self.source.events;
                let a = events.partition_point(|e| e.t_ns < lo);
                let b = events.partition_point(|e| e.t_ns <= hi);
                for e in &events[a..b] {
                    let t_ns = base + e.t_ns - copy.t0_ns;
                    self.place(e, copy, t_ns, out);
                }
            }
        }
        out[start..].sort_unstable_by_key(|e| (e.t_ns, e.y, e.x, e.polarity as u8));
    }

    /// The sensor pixels that replay recording pixel `(e.x, e.y)` under `copy`: every tile's.
    fn place(&self, e: &Event, copy: &Offset, t_ns: u64, out: &mut Vec<Event>) {
        let (w, h) = (self.source.width, self.source.height);
        let x0 = (e.x + w - copy.dx) % w;
        let y0 = (e.y + h - copy.dy) % h;
        let mut y = u32::from(y0);
        while y < u32::from(self.height) {
            let mut x = u32::from(x0);
            while x < u32::from(self.width) {
                out.push(Event {
                    t_ns,
                    x: x as u16,
                    y: y as u16,
                    polarity: e.polarity,
                });
                x += u32::from(w);
            }
            y += u32::from(h);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::event::Polarity;

    fn noise(events: Vec<Event>, w: u16, h: u16, duration_ns: u64) -> Arc<RealNoise> {
        let fitted = fit(&events, w, h, Background::Isolated).expect("fit");
        Arc::new(RealNoise {
            name: "test".into(),
            digest: String::new(),
            width: w,
            height: h,
            duration_ns,
            events,
            fitted,
        })
    }

    fn on(t_ns: u64, x: u16, y: u16) -> Event {
        Event {
            t_ns,
            x,
            y,
            polarity: Polarity::On,
        }
    }

    #[test]
    fn the_recording_is_tiled_and_looped_whatever_the_calls() {
        let source = noise(vec![on(10, 1, 0), on(60, 0, 1)], 2, 2, 100);
        let mut tiler = RealNoiseTiler::new(source, 1, 5, 3, 9);
        tiler.start(1000);
        let mut whole = Vec::new();
        tiler.fill(1400, &mut whole);
        // Two events a 100 ns lap, each at every tile of the 2×2 recording over 5×3: the
        // sensor pixels replaying those two recording pixels (7 or 8 of the 15, as the offsets
        // fall), each once a lap, 4 laps.
        assert!(whole.iter().all(|e| e.t_ns > 1000 && e.t_ns <= 1400));
        assert!(whole.windows(2).all(|p| p[0].t_ns <= p[1].t_ns));
        let mut per_pixel = std::collections::BTreeMap::new();
        for e in &whole {
            *per_pixel.entry((e.x, e.y)).or_insert(0) += 1;
        }
        assert!(per_pixel.values().all(|&n| n == 4), "{per_pixel:?}");
        assert!((7..=8).contains(&per_pixel.len()), "{per_pixel:?}");
        // Cut into many calls, the same events.
        let source = noise(vec![on(10, 1, 0), on(60, 0, 1)], 2, 2, 100);
        let mut pieces = RealNoiseTiler::new(source, 1, 5, 3, 9);
        pieces.start(1000);
        let mut cut = Vec::new();
        for to in (1007..=1400).step_by(7).chain([1400]) {
            pieces.fill(to, &mut cut);
        }
        assert_eq!(cut, whole);
    }

    #[test]
    fn copies_have_their_own_offsets_and_a_seed_fixes_them() {
        let events: Vec<Event> = (0..50).map(|k| on(k * 20, (k % 7) as u16, 0)).collect();
        let source = noise(events, 7, 1, 1000);
        let run = |seed| {
            let mut t = RealNoiseTiler::new(source.clone(), 3, 7, 1, seed);
            t.start(0);
            let mut out = Vec::new();
            t.fill(5000, &mut out);
            out
        };
        assert_eq!(run(4), run(4));
        assert_ne!(run(4), run(5));
        assert_eq!(run(4).len(), 3 * 5 * 50);
    }
}
