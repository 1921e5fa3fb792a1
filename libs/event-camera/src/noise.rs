//! A seeded, v2e-style noisy sensor: [`EventNoise`] and the [`NoisyConverter`].
//!
//! The ideal converter ([`crate::Converter`]) models a perfect pixel. Real DVS pixels are not
//! perfect; to study decoding under sensor noise this module adds the non-idealities of the v2e
//! model (Y. Hu, S.-C. Liu, T. Delbruck, "v2e: From Video Frames to Realistic DVS Events",
//! CVPRW 2021) in its spirit, on top of *exactly* the ideal model's rules (see the crate docs):
//!
//! | term | field | unit | effect |
//! | --- | --- | --- | --- |
//! | threshold mismatch | `threshold_sigma` | log intensity | pixel i has its own threshold `C_i = max(C + σ·z_i, MIN_THRESHOLD)`, `z_i ~ N(0, 1)`, drawn once |
//! | refractory period | `refractory_ns` | ns | a crossing less than this after the pixel's previous *emitted* crossing is not emitted; the level still follows the input |
//! | leak | `leak_hz` | Hz | the reference drifts down by `leak_hz·C_i` per second, so a static pixel emits ON events at `leak_hz` |
//! | shot noise | `shot_noise_hz` | Hz per pixel | spurious events, a Poisson process per pixel, ON/OFF with equal probability; the reference does not move |
//! | hot pixels | `hot_pixels`, `hot_pixel_hz` | count, Hz | that many distinct pixels each add ON events periodically at `hot_pixel_hz` |
//!
//! # Exact rules
//!
//! With `L`, `L_init`, the integer level `n`, the crossing test and the interpolated crossing
//! time exactly those of the ideal converter, pixel i uses
//!
//! * `C_i` in place of `C` in every comparison and interpolation (`f64::from(n ± 1) * C_i`);
//! * `d(t) = (L(t) − L_init) + C_i·(φ_i + g(t))` in place of `d = L − L_init`, with
//!   `g(t) = leak_hz · ((t − t_first) as f64 · 1e-9)` (one value per frame, `t_first` the first
//!   frame's stamp) and leak phase `φ_i ~ U[0, 1)`. The leak term is linear in t, so
//!   interpolating `d` linearly between frames is still exact for a linearly interpolated `L`.
//!   With `leak_hz = 0` there is no leak term at all (not even `φ_i`): `d = L − L_init`;
//! * refractory filter: a crossing at `t` is emitted only if `t ≥ t_emit + refractory_ns`,
//!   `t_emit` the time of the pixel's previous emitted crossing (always emitted if none);
//!   filtered crossings still move the level;
//! * shot noise: for each interval `(t0, t1]` a count `~ Poisson(shot_noise_hz · pixels ·
//!   (t1 − t0)·1e-9)`, each event at a uniform pixel, a uniform integer time in `(t0, t1]` and
//!   a fair polarity;
//! * hot pixel j (distinct pixels chosen by the seed, phase `ψ_j ~ U[0, 1)`): ON events at
//!   `t_first + max(1, ceil((k + ψ_j) · 1e9 / hot_pixel_hz))`, k = 0, 1, …, each in the
//!   interval containing it.
//!
//! Events of one interval are sorted by (time, pixel index, order), where order is the crossing
//! order for threshold crossings, which come before a hot pixel's event, which comes before
//! shot events (in draw order). Shot and hot-pixel events are not subject to the refractory
//! period and never move a reference.
//!
//! # Simplifications against v2e
//!
//! No photoreceptor low-pass filter or intensity-dependent bandwidth, one threshold per pixel for
//! both polarities (no separate ON/OFF mismatch), no threshold drift over time, shot noise
//! independent of intensity, a leak rate common to all pixels (only its phase is random), and
//! hot pixels that are periodic rather than random.
//!
//! # Seeds
//!
//! Every random draw comes from `ChaCha8Rng::seed_from_u64(seed)` with one stream per term
//! (`set_stream`: 1 threshold map, 2 leak phases, 3 shot noise, 4 hot pixels), so changing one
//! term never changes another's draws. The same seed, configuration and frames give the same
//! events, byte for byte; the shot-noise stream advances interval by interval, so it also
//! depends on the frame stamps.
//!
//! # Speed
//!
//! Without leak a pixel's input can only cross a level when its luminance key changes, so the
//! converter keeps the ideal converter's per-pixel key bounds (with `C_i`) and its vectorised
//! scan, and [`NoisyConverter::push_region`] skips unchanged pixels exactly. With leak every
//! pixel's `d` moves every frame: each push evaluates `d` at every pixel (a table log, a few
//! flops), and `push_region` converts the whole frame.

use proto::PixelRect;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Poisson, StandardNormal};

use crate::converter::no_event_bounds;
use crate::error::{ConvertError, MIN_THRESHOLD, NoiseError};
use crate::event::{Event, Polarity};
use crate::kernel::{CHUNK, Isa, scan};
use crate::luminance::{log_table, luminance_key};

/// Largest accepted rate of any noise term (leak, shot noise, hot pixels), Hz per pixel: real
/// sensors are well below; the bound catches unit slips before they fill memory with events.
pub const MAX_NOISE_RATE_HZ: f64 = 1e4;

/// Sensor non-idealities of the v2e model; all zero = the ideal sensor.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct EventNoise {
    /// Per-pixel contrast-threshold mismatch: each pixel's threshold `C_i ~ N(C, σ²)`, σ in
    /// log-intensity units (drawn once per pixel from the seed, clamped to ≥ `MIN_THRESHOLD`).
    pub threshold_sigma: f64,
    /// Refractory period, ns: after a pixel emits, its further crossings within this time still
    /// move its reference level (it follows the input) but emit nothing.
    pub refractory_ns: u64,
    /// Leak rate, Hz: the reference drifts down by `leak_hz·C_i` per second, so a static pixel
    /// emits ON events at ≈ `leak_hz` (random initial phase per pixel).
    pub leak_hz: f64,
    /// Shot noise, Hz per pixel: a Poisson process of spurious events per pixel, polarity ON/OFF
    /// with equal probability, not changing the reference.
    pub shot_noise_hz: f64,
    /// Number of hot pixels (chosen by seed, distinct), each emitting ON events periodically at
    /// `hot_pixel_hz` with a random phase.
    pub hot_pixels: u32,
    /// Rate of each hot pixel, Hz.
    pub hot_pixel_hz: f64,
    /// Seed of every random draw (threshold map, leak phases, shot noise, hot pixels).
    pub seed: u64,
}

impl EventNoise {
    /// True when no term is active (the seed is irrelevant then): the ideal sensor.
    pub fn is_ideal(&self) -> bool {
        self.threshold_sigma == 0.0
            && self.refractory_ns == 0
            && self.leak_hz == 0.0
            && self.shot_noise_hz == 0.0
            && self.hot_pixels == 0
    }

    /// Checks every field: finite and non-negative, rates at most [`MAX_NOISE_RATE_HZ`],
    /// `hot_pixel_hz > 0` when there are hot pixels. The error names the field and its value.
    /// (Whether the hot pixels fit the sensor is checked by [`NoisyConverter::new`].)
    pub fn validate(&self) -> Result<(), NoiseError> {
        let fields = [
            ("threshold_sigma", self.threshold_sigma, false),
            ("leak_hz", self.leak_hz, true),
            ("shot_noise_hz", self.shot_noise_hz, true),
            ("hot_pixel_hz", self.hot_pixel_hz, true),
        ];
        for (field, value, is_rate) in fields {
            if !(value.is_finite() && value >= 0.0) {
                return Err(NoiseError::NotFiniteNonNegative { field, value });
            }
            if is_rate && value > MAX_NOISE_RATE_HZ {
                return Err(NoiseError::RateTooHigh {
                    field,
                    value,
                    max: MAX_NOISE_RATE_HZ,
                });
            }
        }
        if self.hot_pixels > 0 && self.hot_pixel_hz <= 0.0 {
            return Err(NoiseError::HotPixelRateNotPositive {
                hot_pixels: self.hot_pixels,
                value: self.hot_pixel_hz,
            });
        }
        Ok(())
    }
}

/// RNG stream of each term (see the module docs).
const STREAM_THRESHOLD: u64 = 1;
const STREAM_LEAK: u64 = 2;
const STREAM_SHOT: u64 = 3;
const STREAM_HOT: u64 = 4;

fn rng_stream(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    rng
}

/// Sort order of a hot pixel's event: after every threshold crossing of its pixel and time.
const ORDER_HOT: u32 = 1 << 31;
/// Sort order of the first shot event of an interval (later ones count up in draw order).
const ORDER_SHOT: u32 = ORDER_HOT + 1;

/// (t, pixel index, order, polarity) of one event of the interval being converted.
type Crossing = (u64, u32, u32, Polarity);

#[derive(Clone, Debug)]
struct HotPixel {
    index: u32,
    /// ψ_j in [0, 1).
    phase: f64,
    /// k of its next event.
    next: u64,
}

/// Per-pixel state once the first frame has been seen.
#[derive(Clone)]
struct State {
    first_stamp_ns: u64,
    last_stamp_ns: u64,
    /// Keys of the previous frame (start of the interpolation interval).
    prev_keys: Vec<u32>,
    /// Without leak: scratch for the keys of the frame being converted (swapped afterwards).
    keys: Vec<u32>,
    /// Without leak: each pixel's closed no-event key interval `[lo, lo + span]`.
    lo: Vec<u32>,
    span: Vec<u32>,
    l_init: Vec<f64>,
    level: Vec<i32>,
    /// With a refractory period: earliest time the pixel may emit again (0: any time).
    ready_at: Vec<u64>,
    flagged: Vec<u32>,
    crossings: Vec<Crossing>,
}

/// The interval `(t0, t0 + dt]` between two frames and the refractory period.
struct Interval {
    t0: u64,
    dt: u64,
    refractory_ns: u64,
}

impl Interval {
    /// Crossings of pixel `i` from `d0` to `d1` with threshold `c`, starting at `level`;
    /// appends the emitted ones to `out` and returns the new level. `ready_at` is empty when
    /// there is no refractory period.
    #[inline]
    #[expect(
        clippy::too_many_arguments,
        reason = "one pixel's scalars and the two outputs"
    )]
    fn cross(
        &self,
        i: usize,
        d0: f64,
        d1: f64,
        c: f64,
        mut level: i32,
        ready_at: &mut [u64],
        out: &mut Vec<Crossing>,
    ) -> i32 {
        let time_of = |level: i32| {
            let frac = (f64::from(level) * c - d0) / (d1 - d0);
            self.t0 + ((frac * self.dt as f64).ceil() as u64).clamp(1, self.dt)
        };
        let refractory_ns = self.refractory_ns;
        let mut order = 0u32;
        let mut emit = |t: u64, polarity: Polarity, order: u32| {
            if refractory_ns != 0 {
                if t < ready_at[i] {
                    return;
                }
                ready_at[i] = t.saturating_add(refractory_ns);
            }
            out.push((t, i as u32, order.min(ORDER_HOT - 1), polarity));
        };
        while d1 >= f64::from(level + 1) * c {
            level += 1;
            emit(time_of(level), Polarity::On, order);
            order = order.saturating_add(1);
        }
        while d1 <= f64::from(level - 1) * c {
            level -= 1;
            emit(time_of(level), Polarity::Off, order);
            order = order.saturating_add(1);
        }
        level
    }
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
    /// φ_i of every pixel (empty without leak).
    phases: Vec<f64>,
    hot: Vec<HotPixel>,
    shot_rng: ChaCha8Rng,
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
                    (threshold + noise.threshold_sigma * z).max(MIN_THRESHOLD)
                })
                .collect()
        } else {
            vec![threshold; n]
        };
        let phases = if noise.leak_hz > 0.0 {
            let mut rng = rng_stream(noise.seed, STREAM_LEAK);
            (0..n).map(|_| rng.r#gen::<f64>()).collect()
        } else {
            Vec::new()
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
            table: log_table(),
            thresholds,
            phases,
            hot,
            shot_rng: rng_stream(noise.seed, STREAM_SHOT),
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
        self.phases.get(i).copied().unwrap_or(0.0)
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
        if self.noise.leak_hz > 0.0 {
            self.convert_leaky(stamp_ns, rgb, &at);
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
        if self.noise.leak_hz > 0.0 {
            self.convert_leaky(stamp_ns, rgb, &at);
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
        if self.noise.leak_hz == 0.0 {
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
        State {
            first_stamp_ns: stamp_ns,
            last_stamp_ns: stamp_ns,
            prev_keys: keys,
            keys: if lo.is_empty() {
                Vec::new()
            } else {
                vec![0; n]
            },
            lo,
            span,
            l_init,
            level: vec![0; n],
            ready_at: if self.noise.refractory_ns > 0 {
                vec![0; n]
            } else {
                Vec::new()
            },
            flagged: Vec::new(),
            crossings: Vec::new(),
        }
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
                state.prev_keys[i] = key;
            }
        }
    }

    /// With leak: `d` of every pixel at the frame's time against its two firing levels.
    fn convert_leaky(&mut self, stamp_ns: u64, rgb: &[u8], at: &Interval) {
        let Some(state) = self.state.as_mut() else {
            return;
        };
        let leak = |t: u64| self.noise.leak_hz * ((t - state.first_stamp_ns) as f64 * 1e-9);
        let (g0, g1) = (leak(at.t0), leak(stamp_ns));
        let table = self.table;
        state.crossings.clear();
        let pixels = rgb
            .chunks_exact(3)
            .zip(&mut state.prev_keys)
            .zip(&mut state.level)
            .zip(&state.l_init)
            .zip(&self.thresholds)
            .zip(&self.phases)
            .enumerate();
        for (i, (((((px, prev_key), level), &l_init), &c), &phase)) in pixels {
            let key = luminance_key(px[0], px[1], px[2]);
            let d1 = (table[key as usize] - l_init) + c * (phase + g1);
            if d1 >= f64::from(*level + 1) * c || d1 <= f64::from(*level - 1) * c {
                let d0 = (table[*prev_key as usize] - l_init) + c * (phase + g0);
                *level = at.cross(
                    i,
                    d0,
                    d1,
                    c,
                    *level,
                    &mut state.ready_at,
                    &mut state.crossings,
                );
            }
            *prev_key = key;
        }
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
        let n = state.level.len();
        let lambda = self.noise.shot_noise_hz * n as f64 * (at.dt as f64 * 1e-9);
        if let Ok(poisson) = Poisson::new(lambda) {
            let count = poisson.sample(&mut self.shot_rng) as u64;
            let rng = &mut self.shot_rng;
            for k in 0..count {
                let i = rng.gen_range(0..n as u32);
                let t = at.t0 + rng.gen_range(1..=at.dt);
                let polarity = if rng.r#gen::<bool>() {
                    Polarity::On
                } else {
                    Polarity::Off
                };
                let order = ORDER_SHOT.saturating_add(k.min(u64::from(u32::MAX)) as u32);
                state.crossings.push((t, i, order, polarity));
            }
        }
        state
            .crossings
            .sort_unstable_by_key(|&(t, i, order, _)| (t, i, order));
        let w = u32::from(self.width);
        out.extend(state.crossings.iter().map(|&(t_ns, i, _, polarity)| Event {
            t_ns,
            x: (i % w) as u16,
            y: (i / w) as u16,
            polarity,
        }));
        state.last_stamp_ns = stamp_ns;
    }
}

impl State {
    /// Without leak: pixel `i` (threshold `c`) now has key `key` (its previous key still in
    /// `prev_keys`): records its crossings and its new level and bounds. No-op in bounds.
    #[inline]
    fn settle(&mut self, i: usize, key: u32, c: f64, table: &[f64], at: &Interval) {
        if key.wrapping_sub(self.lo[i]) <= self.span[i] {
            return;
        }
        let l_init = self.l_init[i];
        let d0 = table[self.prev_keys[i] as usize] - l_init;
        let d1 = table[key as usize] - l_init;
        let level = at.cross(
            i,
            d0,
            d1,
            c,
            self.level[i],
            &mut self.ready_at,
            &mut self.crossings,
        );
        self.level[i] = level;
        (self.lo[i], self.span[i]) = no_event_bounds(table, l_init, level, c);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_is_ideal_and_valid() {
        let noise = EventNoise::default();
        assert!(noise.is_ideal());
        assert_eq!(noise.validate(), Ok(()));
        let seeded = EventNoise {
            seed: 99,
            hot_pixel_hz: 5.0,
            ..EventNoise::default()
        };
        assert!(
            seeded.is_ideal(),
            "seed and an unused hot-pixel rate are not terms"
        );
    }

    #[test]
    fn each_term_alone_is_not_ideal() {
        let base = EventNoise::default();
        for noise in [
            EventNoise {
                threshold_sigma: 0.01,
                ..base
            },
            EventNoise {
                refractory_ns: 1,
                ..base
            },
            EventNoise {
                leak_hz: 0.1,
                ..base
            },
            EventNoise {
                shot_noise_hz: 0.1,
                ..base
            },
            EventNoise {
                hot_pixels: 1,
                hot_pixel_hz: 1.0,
                ..base
            },
        ] {
            assert!(!noise.is_ideal(), "{noise:?}");
            assert_eq!(noise.validate(), Ok(()), "{noise:?}");
        }
    }

    #[test]
    fn streams_are_independent_and_seeded() {
        let a: u64 = rng_stream(1, STREAM_SHOT).r#gen();
        let b: u64 = rng_stream(1, STREAM_HOT).r#gen();
        let c: u64 = rng_stream(2, STREAM_SHOT).r#gen();
        let again: u64 = rng_stream(1, STREAM_SHOT).r#gen();
        assert_ne!(a, b);
        assert_ne!(a, c);
        assert_eq!(a, again);
    }
}
