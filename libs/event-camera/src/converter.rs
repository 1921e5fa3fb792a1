//! The fast converter: bit-identical to [`crate::reference::ReferenceConverter`].
//!
//! Per pixel it keeps the first frame's luminance key, the integer level n, and the closed
//! interval of luminance keys `[lo, lo + span]` for which the pixel stays at level n, i.e. the
//! keys whose table log `L` satisfies `(n−1)·C < L − L_init < (n+1)·C`. Because the table is
//! non-decreasing these keys are contiguous, and because the bounds are found by searching the
//! same table with the same comparisons as the reference, "in bounds" is *exactly* "no event".
//! A frame therefore costs one integer key and one unsigned compare per pixel; only pixels
//! outside their bounds (all of which emit) touch logarithms, interpolation and a re-search.

use proto::PixelRect;

use crate::error::ConvertError;
use crate::event::{Event, Polarity};
use crate::kernel::{CHUNK, Isa, scan};
use crate::luminance::{log_table, luminance_key};

/// Per-pixel state once the first frame has been seen.
#[derive(Clone)]
struct State {
    last_stamp_ns: u64,
    /// Keys of the previous frame (start of the interpolation interval).
    prev_keys: Vec<u32>,
    /// Scratch for the keys of the frame being converted; swapped with `prev_keys` afterwards.
    keys: Vec<u32>,
    lo: Vec<u32>,
    span: Vec<u32>,
    init_key: Vec<u32>,
    level: Vec<i32>,
    flagged: Vec<u32>,
    /// (t, pixel index, crossing order, polarity) of the interval being converted.
    crossings: Vec<(u64, u32, u32, Polarity)>,
}

/// Fast exact event converter for one sensor.
#[derive(Clone)]
pub struct Converter {
    width: u16,
    height: u16,
    threshold: f64,
    isa: Isa,
    table: &'static [f64],
    state: Option<State>,
}

impl std::fmt::Debug for Converter {
    // The table and per-pixel arrays are megabytes; show what identifies the converter.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Converter")
            .field("width", &self.width)
            .field("height", &self.height)
            .field("threshold", &self.threshold)
            .field("isa", &self.isa)
            .field(
                "last_stamp_ns",
                &self.state.as_ref().map(|s| s.last_stamp_ns),
            )
            .finish_non_exhaustive()
    }
}

impl Converter {
    /// A converter for `width`×`height` RGB frames with contrast threshold `threshold` (C).
    pub fn new(width: u16, height: u16, threshold: f64) -> Result<Self, ConvertError> {
        ConvertError::check_sensor(width, height, threshold)?;
        Ok(Self {
            width,
            height,
            threshold,
            isa: Isa::detect(),
            table: log_table(),
            state: None,
        })
    }

    pub fn width(&self) -> u16 {
        self.width
    }

    pub fn height(&self) -> u16 {
        self.height
    }

    pub fn threshold(&self) -> f64 {
        self.threshold
    }

    /// True once the first frame has initialised the references.
    pub fn is_initialised(&self) -> bool {
        self.state.is_some()
    }

    /// Current integer level n of pixel (x, y) (0 before the first frame).
    pub fn level(&self, x: u16, y: u16) -> i32 {
        let i = usize::from(y) * usize::from(self.width) + usize::from(x);
        self.state
            .as_ref()
            .and_then(|s| s.level.get(i).copied())
            .unwrap_or(0)
    }

    /// Converts the frame rendered at `stamp_ns` (row-major RGB, 3 bytes per pixel) and
    /// **appends** the events of the interval since the previous frame to `out`, sorted by
    /// (time, pixel index, crossing order). The first frame only initialises. On error nothing
    /// changes.
    pub fn push(
        &mut self,
        stamp_ns: u64,
        rgb: &[u8],
        out: &mut Vec<Event>,
    ) -> Result<(), ConvertError> {
        ConvertError::check_frame(rgb, self.width, self.height)?;
        let n = usize::from(self.width) * usize::from(self.height);
        let Some(state) = self.state.as_mut() else {
            self.state = Some(self.initial_state(stamp_ns, rgb));
            return Ok(());
        };
        ConvertError::check_stamp(stamp_ns, state.last_stamp_ns)?;
        scan(
            self.isa,
            rgb,
            &state.lo,
            &state.span,
            &mut state.keys,
            &mut state.flagged,
        );
        let interval = Interval::new(state.last_stamp_ns, stamp_ns, self.threshold, self.table);
        state.crossings.clear();
        for k in 0..state.flagged.len() {
            let start = state.flagged[k] as usize * CHUNK;
            for i in start..(start + CHUNK).min(n) {
                let key = state.keys[i];
                state.settle(i, key, &interval);
            }
        }
        std::mem::swap(&mut state.keys, &mut state.prev_keys);
        state.finish(stamp_ns, self.width, out);
        Ok(())
    }

    /// Like [`Converter::push`] for a frame known to equal the previous one outside `region`
    /// (`None`: equal everywhere). Only the region's pixels are read; the events are exactly
    /// those a full push of the frame gives, because a pixel whose key did not change cannot
    /// cross a level. The first frame must be a full [`Converter::push`].
    pub fn push_region(
        &mut self,
        stamp_ns: u64,
        rgb: &[u8],
        region: Option<PixelRect>,
        out: &mut Vec<Event>,
    ) -> Result<(), ConvertError> {
        let width = usize::from(self.width);
        ConvertError::check_frame(rgb, self.width, self.height)?;
        ConvertError::check_region(region, self.width, self.height)?;
        let Some(state) = self.state.as_mut() else {
            return Err(ConvertError::RegionBeforeFirstFrame);
        };
        ConvertError::check_stamp(stamp_ns, state.last_stamp_ns)?;
        let interval = Interval::new(state.last_stamp_ns, stamp_ns, self.threshold, self.table);
        state.crossings.clear();
        if let Some(r) = region {
            for y in usize::from(r.y)..usize::from(r.y) + usize::from(r.height) {
                let row = y * width;
                for i in row + usize::from(r.x)..row + usize::from(r.x) + usize::from(r.width) {
                    let key = luminance_key(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]);
                    state.settle(i, key, &interval);
                    state.prev_keys[i] = key;
                }
            }
        }
        state.finish(stamp_ns, self.width, out);
        Ok(())
    }

    fn initial_state(&self, stamp_ns: u64, rgb: &[u8]) -> State {
        let n = rgb.len() / 3;
        let keys: Vec<u32> = rgb
            .chunks_exact(3)
            .map(|p| luminance_key(p[0], p[1], p[2]))
            .collect();
        let (mut lo, mut span) = (vec![0; n], vec![0; n]);
        // Rendered backgrounds repeat keys along rows; reuse the last search when they do.
        let mut memo: Option<(u32, (u32, u32))> = None;
        for (i, &key) in keys.iter().enumerate() {
            let bounds = match memo {
                Some((k, b)) if k == key => b,
                _ => {
                    let b =
                        no_event_bounds(self.table, self.table[key as usize], 0, self.threshold);
                    memo = Some((key, b));
                    b
                }
            };
            (lo[i], span[i]) = bounds;
        }
        State {
            last_stamp_ns: stamp_ns,
            prev_keys: keys.clone(),
            keys: vec![0; n],
            lo,
            span,
            init_key: keys,
            level: vec![0; n],
            flagged: Vec::new(),
            crossings: Vec::new(),
        }
    }
}

/// The interval `(t0, t0 + dt]` between two frames and the constants of its crossings.
struct Interval {
    t0: u64,
    dt: u64,
    c: f64,
    table: &'static [f64],
}

impl Interval {
    fn new(t0: u64, t1: u64, c: f64, table: &'static [f64]) -> Self {
        Self {
            t0,
            dt: t1 - t0,
            c,
            table,
        }
    }
}

impl State {
    /// Pixel `i` now has luminance key `key` (its previous key still in `prev_keys`): records
    /// its crossings of the interval and its new level and bounds. No-op when `key` is in bounds.
    fn settle(&mut self, i: usize, key: u32, at: &Interval) {
        if key.wrapping_sub(self.lo[i]) <= self.span[i] {
            return;
        }
        let (c, table) = (at.c, at.table);
        let l_init = table[self.init_key[i] as usize];
        let d0 = table[self.prev_keys[i] as usize] - l_init;
        let d1 = table[key as usize] - l_init;
        let time_of = |level: i32| {
            let frac = (f64::from(level) * c - d0) / (d1 - d0);
            at.t0 + ((frac * at.dt as f64).ceil() as u64).clamp(1, at.dt)
        };
        let mut level = self.level[i];
        let mut order = 0;
        while d1 >= f64::from(level + 1) * c {
            level += 1;
            self.crossings
                .push((time_of(level), i as u32, order, Polarity::On));
            order += 1;
        }
        while d1 <= f64::from(level - 1) * c {
            level -= 1;
            self.crossings
                .push((time_of(level), i as u32, order, Polarity::Off));
            order += 1;
        }
        self.level[i] = level;
        (self.lo[i], self.span[i]) = no_event_bounds(table, l_init, level, c);
    }

    /// Sorts the interval's crossings into events appended to `out` and closes the interval.
    fn finish(&mut self, stamp_ns: u64, width: u16, out: &mut Vec<Event>) {
        self.crossings
            .sort_unstable_by_key(|&(t, i, order, _)| (t, i, order));
        let w = u32::from(width);
        out.extend(self.crossings.iter().map(|&(t_ns, i, _, polarity)| Event {
            t_ns,
            x: (i % w) as u16,
            y: (i / w) as u16,
            polarity,
        }));
        self.last_stamp_ns = stamp_ns;
    }
}

/// `(lo, span)` such that key k keeps a pixel at `level` iff `lo ≤ k ≤ lo + span`, i.e.
/// `(level−1)·C < table[k] − l_init < (level+1)·C` — the reference's firing conditions negated,
/// evaluated with the same f64 operations. The interval is never empty for a pixel that has just
/// settled at `level` (its own key is inside).
pub(crate) fn no_event_bounds(table: &[f64], l_init: f64, level: i32, c: f64) -> (u32, u32) {
    let fires_down = f64::from(level - 1) * c;
    let fires_up = f64::from(level + 1) * c;
    let lo = first_false(
        table,
        |l| l - l_init <= fires_down,
        key_guess(l_init + fires_down),
    );
    let hi_exclusive = first_false(
        table,
        |l| l - l_init < fires_up,
        key_guess(l_init + fires_up),
    );
    debug_assert!(lo < hi_exclusive, "empty no-event interval");
    (lo as u32, (hi_exclusive - 1 - lo) as u32)
}

/// The key whose log luminance is about `l` — only a starting point for [`first_false`], so its
/// accuracy affects speed, never results.
fn key_guess(l: f64) -> usize {
    // Saturating float→int conversion: NaN and negatives become 0, overflow the maximum.
    (1000.0 * l.exp()).round() as usize
}

/// First index of the non-decreasing `table` where `pred` is false (`table.len()` if none),
/// `pred` being true on a prefix. Gallops outwards from `guess`, then bisects the bracket, so a
/// good guess costs a handful of probes within a few cache lines instead of a full bisection.
fn first_false(table: &[f64], pred: impl Fn(f64) -> bool, guess: usize) -> usize {
    let n = table.len();
    let guess = guess.min(n - 1);
    let (mut lo, mut hi); // answer in [lo, hi]
    if pred(table[guess]) {
        (lo, hi) = (guess + 1, n);
        let mut step = 1;
        while guess + step < n {
            if !pred(table[guess + step]) {
                hi = guess + step;
                break;
            }
            lo = guess + step + 1;
            step *= 2;
        }
    } else {
        (lo, hi) = (0, guess);
        let mut step = 1;
        while step <= guess {
            if pred(table[guess - step]) {
                lo = guess - step + 1;
                break;
            }
            hi = guess - step;
            step *= 2;
        }
    }
    lo + table[lo..hi].partition_point(|&l| pred(l))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_false_agrees_with_bisection_for_any_guess() {
        let table = log_table();
        for &(threshold, l_init) in &[
            (0.5, 0.0),
            (2.0, 3.0),
            (-0.18, 4.6),
            (5.6, 0.1),
            (-9.0, 1.0),
        ] {
            let pred = |l: f64| l - l_init <= threshold;
            let want = table.partition_point(|&l| pred(l));
            for guess in [
                0,
                1,
                999,
                1000,
                1001,
                want.saturating_sub(3),
                want,
                want + 7,
                200_000,
            ]
            .into_iter()
            .chain([usize::MAX, table.len(), table.len() - 1])
            {
                assert_eq!(
                    first_false(table, pred, guess),
                    want,
                    "t={threshold} guess={guess}"
                );
            }
        }
    }

    #[test]
    fn bounds_are_exactly_the_no_event_keys() {
        let table = log_table();
        let c = 0.18;
        for (init_key, level) in [
            (0, 0),
            (500, 3),
            (100_000, 0),
            (100_000, -2),
            (255_000, 0),
            (1_500, 7),
        ] {
            let l_init = table[init_key];
            let (lo, span) = no_event_bounds(table, l_init, level, c);
            for (k, &l) in table.iter().enumerate() {
                let d = l - l_init;
                let quiet = f64::from(level - 1) * c < d && d < f64::from(level + 1) * c;
                let inside = (lo as usize..=(lo + span) as usize).contains(&k);
                assert_eq!(inside, quiet, "init {init_key} level {level} key {k}");
            }
        }
    }
}
