//! The noisy converter: the ideal converter's rules with [`EventNoise`]'s terms (see the
//! module docs of [`super`]).

use proto::PixelRect;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Poisson, StandardNormal};

use super::leak::LeakModel;
use super::schedule::LeakSchedule;
use super::shot::{PixelKeys, ShotDraws, ShotMap};
use super::state::{Interval, ORDER_HOT, PixelJudge, State};
use super::{
    EventNoise, MIN_PIXEL_THRESHOLD, STREAM_HOT, STREAM_SHOT, STREAM_THRESHOLD, rng_stream,
};
use crate::converter::no_event_bounds;
use crate::error::{ConvertError, NoiseError};
use crate::event::{Event, Polarity};
use crate::kernel::{CHUNK, Isa, scan};
use crate::luminance::{luminance_key, table_for};

#[derive(Clone, Debug)]
struct HotPixel {
    index: u32,
    /// ψ_j in [0, 1).
    phase: f64,
    /// k of its next event.
    next: u64,
}

/// Event converter with the [`EventNoise`] non-idealities; with ideal noise its events are
/// bit-identical to [`crate::Converter`]'s.
#[derive(Clone)]
pub struct NoisyConverter {
    width: u16,
    height: u16,
    threshold: f64,
    noise: EventNoise,
    isa: Isa,
    table: &'static [f64],
    /// C_i of every pixel.
    thresholds: Vec<f64>,
    /// φ_i, s_i and the jitter of every pixel's leak (empty without leak).
    leak: LeakModel,
    hot: Vec<HotPixel>,
    shot_map: ShotMap,
    shot_rng: ChaCha8Rng,
    /// Scratch of the interval's shot events.
    shot: ShotDraws,
    state: Option<State>,
}

impl std::fmt::Debug for NoisyConverter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NoisyConverter")
            .field("width", &self.width)
            .field("height", &self.height)
            .field("threshold", &self.threshold)
            .field("noise", &self.noise)
            .field(
                "last_stamp_ns",
                &self.state.as_ref().map(|s| s.last_stamp_ns),
            )
            .finish_non_exhaustive()
    }
}

impl NoisyConverter {
    /// A converter for `width`×`height` RGB frames with nominal contrast threshold `threshold`
    /// (C) and the non-idealities `noise`. Draws the threshold map, leak phases and hot pixels.
    pub fn new(
        width: u16,
        height: u16,
        threshold: f64,
        noise: &EventNoise,
    ) -> Result<Self, ConvertError> {
        ConvertError::check_sensor(width, height, threshold)?;
        noise.validate()?;
        let n = usize::from(width) * usize::from(height);
        if noise.hot_pixels as usize > n {
            return Err(NoiseError::TooManyHotPixels {
                hot_pixels: noise.hot_pixels,
                pixels: n,
            }
            .into());
        }
        let thresholds = if noise.threshold_sigma > 0.0 {
            let mut rng = rng_stream(noise.seed, STREAM_THRESHOLD);
            (0..n)
                .map(|_| {
                    let z: f64 = rng.sample(StandardNormal);
                    (threshold + noise.threshold_sigma * z).max(MIN_PIXEL_THRESHOLD.min(threshold))
                })
                .collect()
        } else {
            vec![threshold; n]
        };
        let hot = if noise.hot_pixels > 0 {
            let mut rng = rng_stream(noise.seed, STREAM_HOT);
            let chosen = rand::seq::index::sample(&mut rng, n, noise.hot_pixels as usize);
            chosen
                .into_iter()
                .map(|index| HotPixel {
                    index: index as u32,
                    phase: rng.r#gen::<f64>(),
                    next: 0,
                })
                .collect()
        } else {
            Vec::new()
        };
        Ok(Self {
            width,
            height,
            threshold,
            noise: *noise,
            isa: Isa::detect(),
            table: table_for(noise.linlog_dn),
            leak: LeakModel::new(noise, n),
            shot_map: ShotMap::new(threshold, &thresholds, noise.shot_noise_bright_drop),
            thresholds,
            hot,
            shot_rng: rng_stream(noise.seed, STREAM_SHOT),
            shot: ShotDraws::default(),
            state: None,
        })
    }

    pub fn width(&self) -> u16 {
        self.width
    }

    pub fn height(&self) -> u16 {
        self.height
    }

    /// Nominal contrast threshold C.
    pub fn threshold(&self) -> f64 {
        self.threshold
    }

    pub fn noise(&self) -> &EventNoise {
        &self.noise
    }

    /// True once the first frame has initialised the references.
    pub fn is_initialised(&self) -> bool {
        self.state.is_some()
    }

    fn index(&self, x: u16, y: u16) -> usize {
        usize::from(y) * usize::from(self.width) + usize::from(x)
    }

    /// Current integer level n of pixel (x, y) (0 before the first frame or outside).
    pub fn level(&self, x: u16, y: u16) -> i32 {
        let i = self.index(x, y);
        self.state
            .as_ref()
            .and_then(|s| s.level.get(i).copied())
            .unwrap_or(0)
    }

    /// Contrast threshold `C_i` of pixel (x, y) (NaN outside the sensor).
    pub fn threshold_of(&self, x: u16, y: u16) -> f64 {
        self.thresholds
            .get(self.index(x, y))
            .copied()
            .unwrap_or(f64::NAN)
    }

    /// Leak phase `φ_i` of pixel (x, y) in [0, 1) (0 without leak, NaN outside the sensor).
    pub fn leak_phase_of(&self, x: u16, y: u16) -> f64 {
        let i = self.index(x, y);
        if i >= self.thresholds.len() {
            return f64::NAN;
        }
        self.leak.phases.get(i).copied().unwrap_or(0.0)
    }

    /// Leak rate of pixel (x, y) relative to `leak_hz` (`s_i`; 1 without spread, NaN outside).
    pub fn leak_scale_of(&self, x: u16, y: u16) -> f64 {
        let i = self.index(x, y);
        if i >= self.thresholds.len() {
            return f64::NAN;
        }
        self.leak.scale(i)
    }

    /// Slope of pixel (x, y)'s leak sum in leak period `m` (`w_{i,m}`; 1 without jitter).
    pub fn leak_weight_of(&self, x: u16, y: u16, m: u32) -> f64 {
        self.leak.weight(self.index(x, y), m)
    }

    /// The log intensity the pixels see: `L` of a luminance key (lin-log or log curve).
    pub fn log_intensity_of_key(&self, key: u32) -> f64 {
        self.table.get(key as usize).copied().unwrap_or(f64::NAN)
    }

    /// True when pixels must be judged one by one (leak or low-pass), not by key bounds.
    fn judged(&self) -> bool {
        self.noise.leak_hz > 0.0 || self.noise.cutoff_hz > 0.0
    }

    /// The hot pixels (x, y), in the order they were drawn.
    pub fn hot_pixel_positions(&self) -> Vec<(u16, u16)> {
        let w = u32::from(self.width);
        self.hot
            .iter()
            .map(|h| ((h.index % w) as u16, (h.index / w) as u16))
            .collect()
    }

    /// Converts the frame rendered at `stamp_ns` (row-major RGB, 3 bytes per pixel) and
    /// **appends** the events of the interval since the previous frame to `out`, sorted by
    /// (time, pixel index, order). The first frame only initialises. On error nothing changes.
    pub fn push(
        &mut self,
        stamp_ns: u64,
        rgb: &[u8],
        out: &mut Vec<Event>,
    ) -> Result<(), ConvertError> {
        ConvertError::check_frame(rgb, self.width, self.height)?;
        if self.state.is_none() {
            self.state = Some(self.initial_state(stamp_ns, rgb));
            return Ok(());
        }
        let at = self.interval(stamp_ns)?;
        if self.judged() {
            let full = PixelRect {
                x: 0,
                y: 0,
                width: self.width,
                height: self.height,
            };
            self.convert_judged(stamp_ns, rgb, Some(full), &at);
        } else {
            self.convert_scan(rgb, &at);
        }
        self.finish(stamp_ns, &at, out);
        Ok(())
    }

    /// Like [`NoisyConverter::push`] for a frame known to equal the previous one outside
    /// `region` (`None`: equal everywhere), with exactly the events of a full push. Without leak
    /// only the region's pixels are read (an unchanged key cannot cross a level); with leak
    /// every pixel moves, so the whole frame is converted. The first frame must be a full push.
    pub fn push_region(
        &mut self,
        stamp_ns: u64,
        rgb: &[u8],
        region: Option<PixelRect>,
        out: &mut Vec<Event>,
    ) -> Result<(), ConvertError> {
        ConvertError::check_frame(rgb, self.width, self.height)?;
        ConvertError::check_region(region, self.width, self.height)?;
        if self.state.is_none() {
            return Err(ConvertError::RegionBeforeFirstFrame);
        }
        let at = self.interval(stamp_ns)?;
        if self.judged() {
            self.convert_judged(stamp_ns, rgb, region, &at);
        } else if let Some(r) = region {
            self.convert_region(rgb, r, &at);
        } else if let Some(state) = self.state.as_mut() {
            state.crossings.clear();
        }
        self.finish(stamp_ns, &at, out);
        Ok(())
    }

    /// The interval ending at `stamp_ns`; the state must exist.
    fn interval(&self, stamp_ns: u64) -> Result<Interval, ConvertError> {
        let last = self.state.as_ref().map_or(0, |s| s.last_stamp_ns);
        ConvertError::check_stamp(stamp_ns, last)?;
        Ok(Interval {
            t0: last,
            dt: stamp_ns - last,
            refractory_ns: self.noise.refractory_ns,
        })
    }

    fn initial_state(&self, stamp_ns: u64, rgb: &[u8]) -> State {
        let n = rgb.len() / 3;
        let keys: Vec<u32> = rgb
            .chunks_exact(3)
            .map(|p| luminance_key(p[0], p[1], p[2]))
            .collect();
        let l_init: Vec<f64> = keys.iter().map(|&k| self.table[k as usize]).collect();
        let (mut lo, mut span) = (Vec::new(), Vec::new());
        let judged = self.judged();
        if !judged {
            (lo, span) = (vec![0; n], vec![0; n]);
            // Rendered backgrounds repeat keys along rows; with one threshold for all pixels
            // the last search is reused when they do.
            let mut memo: Option<(u32, u64, (u32, u32))> = None;
            for (i, &key) in keys.iter().enumerate() {
                let c = self.thresholds[i];
                let bounds = match memo {
                    Some((k, cb, b)) if k == key && cb == c.to_bits() => b,
                    _ => {
                        let b = no_event_bounds(self.table, l_init[i], 0, c);
                        memo = Some((key, c.to_bits(), b));
                        b
                    }
                };
                (lo[i], span[i]) = bounds;
            }
        }
        let mut state = State {
            first_stamp_ns: stamp_ns,
            last_stamp_ns: stamp_ns,
            prev_keys: keys,
            coarse: Vec::new(),
            keys: if lo.is_empty() {
                Vec::new()
            } else {
                vec![0; n]
            },
            lo,
            span,
            level: vec![0; n],
            ready_at: if self.noise.refractory_ns > 0 {
                vec![0; n]
            } else {
                Vec::new()
            },
            leak: if self.noise.leak_hz > 0.0 {
                let jitter = self.leak.cache();
                // Level 0, d = C·Λ_i(g): the first crossing where Λ_i(g) = 1.
                LeakSchedule::new((0..n).map(|i| self.leak.due(&jitter, i, 0, 0.0, 1.0)))
            } else {
                LeakSchedule::default()
            },
            jitter: self.leak.cache(),
            lp: if self.noise.cutoff_hz > 0.0 {
                l_init.clone()
            } else {
                Vec::new()
            },
            l_init,
            unsettled: Vec::new(),
            is_unsettled: if self.noise.cutoff_hz > 0.0 {
                vec![false; n]
            } else {
                Vec::new()
            },
            judged_ns: if self.noise.cutoff_hz > 0.0 {
                vec![0; n]
            } else {
                Vec::new()
            },
            flagged: Vec::new(),
            crossings: Vec::new(),
            to_judge: Vec::new(),
        };
        state.set_coarse(&self.shot_map);
        state
    }

    /// Without leak, whole frame: the vectorised key scan, then the flagged chunks.
    fn convert_scan(&mut self, rgb: &[u8], at: &Interval) {
        let Some(state) = self.state.as_mut() else {
            return;
        };
        let n = state.level.len();
        scan(
            self.isa,
            rgb,
            &state.lo,
            &state.span,
            &mut state.keys,
            &mut state.flagged,
        );
        state.crossings.clear();
        for k in 0..state.flagged.len() {
            let start = state.flagged[k] as usize * CHUNK;
            for i in start..(start + CHUNK).min(n) {
                let key = state.keys[i];
                state.settle(i, key, self.thresholds[i], self.table, at);
            }
        }
        std::mem::swap(&mut state.keys, &mut state.prev_keys);
        state.set_coarse(&self.shot_map);
    }

    /// Without leak, only `region`'s pixels.
    fn convert_region(&mut self, rgb: &[u8], r: PixelRect, at: &Interval) {
        let Some(state) = self.state.as_mut() else {
            return;
        };
        let width = usize::from(self.width);
        state.crossings.clear();
        for y in usize::from(r.y)..usize::from(r.y) + usize::from(r.height) {
            let row = y * width;
            for i in row + usize::from(r.x)..row + usize::from(r.x) + usize::from(r.width) {
                let key = luminance_key(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]);
                state.settle(i, key, self.thresholds[i], self.table, at);
                state.set_key(i, key, &self.shot_map);
            }
        }
    }

    /// With leak or low-pass: the pixels of `region` whose key changed, the pixels whose
    /// low-passed intensity is still settling, then every pixel whose leak crossing is due by
    /// the frame's time, each judged once, exactly as the rule states (`d` at the frame's time
    /// against its two firing levels). Any other pixel has an unchanged, settled input and a `d`
    /// that only grows with the leak, so it cannot cross before its due time (see
    /// [`LeakSchedule`]): skipping it gives the same events as judging every pixel.
    fn convert_judged(
        &mut self,
        stamp_ns: u64,
        rgb: &[u8],
        region: Option<PixelRect>,
        at: &Interval,
    ) {
        let Some(state) = self.state.as_mut() else {
            return;
        };
        let leak = |t: u64| self.noise.leak_hz * ((t - state.first_stamp_ns) as f64 * 1e-9);
        let (g0, g1) = (leak(at.t0), leak(stamp_ns));
        let pixel = PixelJudge {
            table: self.table,
            thresholds: &self.thresholds,
            leak: (self.noise.leak_hz > 0.0).then_some(&self.leak),
            cutoff_hz: self.noise.cutoff_hz,
            g0,
            g1,
            stamp_ns,
            at,
            shot: &self.shot_map,
        };
        state.crossings.clear();
        let settling = std::mem::take(&mut state.unsettled);
        for &i in &settling {
            state.is_unsettled[i as usize] = false;
        }
        if let Some(r) = region {
            let width = usize::from(self.width);
            for y in usize::from(r.y)..usize::from(r.y) + usize::from(r.height) {
                let row = y * width;
                for i in row + usize::from(r.x)..row + usize::from(r.x) + usize::from(r.width) {
                    let key = luminance_key(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]);
                    if key != state.prev_keys[i] {
                        pixel.judge(state, i, key);
                    }
                }
            }
        }
        // The settling pixels, then those whose leak crossing is due, judged as one list with
        // look-ahead. A pixel judged above is due after g1, so the schedule does not hand it
        // out; a settling pixel that is also due is listed twice and judged once.
        state.to_judge.clear();
        state.to_judge.extend_from_slice(&settling);
        if pixel.leak.is_some() {
            while let Some(i) = state.leak.pop_due(g1) {
                state.to_judge.push(i as u32);
            }
        }
        pixel.judge_listed(state);
    }

    /// Adds the interval's hot-pixel and shot events, sorts, appends to `out`, closes the
    /// interval.
    fn finish(&mut self, stamp_ns: u64, at: &Interval, out: &mut Vec<Event>) {
        let Some(state) = self.state.as_mut() else {
            return;
        };
        if !self.hot.is_empty() {
            let period_ns = 1e9 / self.noise.hot_pixel_hz;
            for hot in &mut self.hot {
                loop {
                    let offset = ((hot.next as f64 + hot.phase) * period_ns).ceil() as u64;
                    let t = state.first_stamp_ns.saturating_add(offset.max(1));
                    if t > stamp_ns {
                        break;
                    }
                    state
                        .crossings
                        .push((t, hot.index, ORDER_HOT, Polarity::On));
                    hot.next += 1;
                }
            }
        }
        state
            .crossings
            .sort_unstable_by_key(|&(t_ns, i, order, _)| (t_ns, i, order));
        let n = state.level.len();
        let lambda =
            self.noise.shot_noise_hz * self.shot_map.mean_weight * n as f64 * (at.dt as f64 * 1e-9);
        let shot = &mut self.shot;
        shot.keys.clear();
        if let Ok(poisson) = Poisson::new(lambda) {
            let count = poisson.sample(&mut self.shot_rng) as u64;
            shot.draw(
                &mut self.shot_rng,
                count,
                n as u32,
                at.dt,
                &self.shot_map,
                &PixelKeys {
                    luminance: &state.prev_keys,
                    coarse: &state.coarse,
                },
            );
        }
        let rows = RowOf::new(self.width);
        let event = |t_ns: u64, i: u32, polarity: Polarity| {
            let y = rows.row(i);
            Event {
                t_ns,
                x: (i - y * u32::from(self.width)) as u16,
                y: y as u16,
                polarity,
            }
        };
        // Merge: crossings and hot events before shot events of the same time and pixel.
        out.reserve(state.crossings.len() + shot.keys.len());
        let mut crossings = state.crossings.iter().peekable();
        for &key in &shot.keys {
            let (t_ns, i, polarity) = shot.unpack(key, at.t0);
            while let Some(&&(tc, ic, _, pc)) = crossings.peek() {
                if (tc, ic) > (t_ns, i) {
                    break;
                }
                out.push(event(tc, ic, pc));
                crossings.next();
            }
            out.push(event(t_ns, i, polarity));
        }
        out.extend(crossings.map(|&(t_ns, i, _, polarity)| event(t_ns, i, polarity)));
        state.last_stamp_ns = stamp_ns;
    }
}

/// `i / width` by a multiply and a shift: a division per event was a quarter of
/// [`NoisyConverter::finish`] in a profile of a noisy trial. With `m = ⌊2⁶⁴/w⌋ + 1`,
/// `m·w = 2⁶⁴ + e`, `0 < e ≤ w`, so `i·m/2⁶⁴ = i/w + i·e/(w·2⁶⁴)`, and the excess is below
/// `1/w` for every u32 `i` (`i·e < 2⁴⁸`): the floor is exactly `⌊i/w⌋`.
#[derive(Clone, Copy)]
struct RowOf {
    m: u128,
}

impl RowOf {
    fn new(width: u16) -> Self {
        Self {
            m: (1u128 << 64) / u128::from(width.max(1)) + 1,
        }
    }

    #[inline(always)]
    fn row(self, i: u32) -> u32 {
        ((u128::from(i) * self.m) >> 64) as u32
    }
}

#[cfg(test)]
mod tests {
    use super::RowOf;

    #[test]
    fn row_of_is_the_quotient() {
        for width in [1u16, 2, 3, 7, 346, 640, 641, 1280, 65_521, u16::MAX] {
            let rows = RowOf::new(width);
            let w = u32::from(width);
            let edges = (1..2_000u32).flat_map(|k| [k * w - 1, k * w, k * w + 1]);
            for i in edges.chain([0, u32::MAX, u32::MAX - 1, u32::MAX / w * w]) {
                assert_eq!(rows.row(i), i / w, "{i} / {width}");
            }
        }
    }
}
