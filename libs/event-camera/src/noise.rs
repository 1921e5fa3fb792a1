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
//! shot events (OFF before ON, then draw order). Shot and hot-pixel events are not subject to
//! the refractory period and never move a reference.
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
//! pixel's `d` grows every frame, but a pixel whose key did not change can only cross upward,
//! at a leak value `g` known in advance: a schedule ordered by that value hands each frame the
//! pixels due by then, besides the ones whose key changed (the region's, or every pixel's on a
//! full push), and each is judged by the exact rule. The events are the same as judging every
//! pixel every frame (the scalar reference in `tests/noise.rs` checks it); the cost is the
//! changed pixels plus about one judgement per leak event.

use proto::PixelRect;
use rand::{Rng, RngCore, SeedableRng};
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
    /// With leak: the pixels whose next upward leak crossing is due, see [`LeakSchedule`].
    leak: LeakSchedule,
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
            let full = PixelRect {
                x: 0,
                y: 0,
                width: self.width,
                height: self.height,
            };
            self.convert_leaky(stamp_ns, rgb, Some(full), &at);
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
            self.convert_leaky(stamp_ns, rgb, region, &at);
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
            leak: if self.noise.leak_hz > 0.0 {
                LeakSchedule::new(self.thresholds.iter().zip(&self.phases).map(|(_, &phase)| {
                    // Level 0, d = C·(φ + g): the first crossing at g = 1 − φ.
                    due_g(0, phase, 0.0, 1.0)
                }))
            } else {
                LeakSchedule::default()
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

    /// With leak: the pixels of `region` whose key changed, then every pixel whose leak
    /// crossing is due by the frame's time, each judged exactly as the rule states (`d` at the
    /// frame's time against its two firing levels). A pixel whose key did not change has a `d`
    /// that only grows with the leak, so it cannot cross before its due time (see
    /// [`LeakSchedule`]): skipping it until then gives the same events as judging every pixel.
    fn convert_leaky(
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
            phases: &self.phases,
            g0,
            g1,
            at,
        };
        state.crossings.clear();
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
        while let Some(i) = state.leak.pop_due(g1) {
            let key = state.prev_keys[i];
            pixel.judge(state, i, key);
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
        state
            .crossings
            .sort_unstable_by_key(|&(t_ns, i, order, _)| (t_ns, i, order));
        let n = state.level.len();
        let lambda = self.noise.shot_noise_hz * n as f64 * (at.dt as f64 * 1e-9);
        let shot = &mut self.shot;
        shot.keys.clear();
        if let Ok(poisson) = Poisson::new(lambda) {
            let count = poisson.sample(&mut self.shot_rng) as u64;
            shot.draw(&mut self.shot_rng, count, n as u32, at.dt);
        }
        let w = u32::from(self.width);
        let event = |t_ns: u64, i: u32, polarity: Polarity| Event {
            t_ns,
            x: (i % w) as u16,
            y: (i / w) as u16,
            polarity,
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

/// One interval's shot events as sortable keys `(t − t0, pixel, polarity)`, packed into a u64
/// (`t − t0` highest), sorted by an LSD radix sort: linear in the count, where a comparison
/// sort of the ≈ 15 000 events of a 10 ms interval at 5 Hz per pixel cost more than drawing
/// them.
#[derive(Clone, Default)]
struct ShotDraws {
    keys: Vec<u64>,
    scratch: Vec<u64>,
    /// Bits of the pixel index field.
    pixel_bits: u32,
}

/// Radix digit width of the shot-event sort.
const RADIX_BITS: u32 = 11;

impl ShotDraws {
    /// Draws `count` events, each at a uniform pixel of `pixels`, a uniform integer time offset
    /// in `1..=dt` and a fair polarity, and sorts them by (time, pixel, polarity).
    fn draw(&mut self, rng: &mut ChaCha8Rng, count: u64, pixels: u32, dt: u64) {
        self.pixel_bits = 32 - pixels.saturating_sub(1).leading_zeros();
        let time_bits = 64 - dt.leading_zeros();
        let bits = time_bits + self.pixel_bits + 1;
        for _ in 0..count {
            let (a, b) = (rng.next_u64(), rng.next_u64());
            // Multiply-shift: a uniform value below the bound from 32 random bits (bias below
            // bound / 2³², negligible for a sensor's pixels); times beyond 32 bits draw exactly.
            let pixel = ((a >> 32) * u64::from(pixels)) >> 32;
            let offset = if dt <= u64::from(u32::MAX) {
                1 + (((b >> 32) * dt) >> 32)
            } else {
                rng.gen_range(1..=dt)
            };
            self.keys
                .push((offset << (self.pixel_bits + 1)) | (pixel << 1) | (b & 1));
        }
        self.sort(bits);
    }

    fn sort(&mut self, bits: u32) {
        let radix = 1usize << RADIX_BITS;
        let mut counts = vec![0usize; radix];
        let mask = (radix - 1) as u64;
        let mut shift = 0;
        while shift < bits {
            counts.fill(0);
            for &k in &self.keys {
                counts[((k >> shift) & mask) as usize] += 1;
            }
            let mut sum = 0;
            for c in &mut counts {
                (*c, sum) = (sum, sum + *c);
            }
            self.scratch.resize(self.keys.len(), 0);
            for &k in &self.keys {
                let d = ((k >> shift) & mask) as usize;
                self.scratch[counts[d]] = k;
                counts[d] += 1;
            }
            std::mem::swap(&mut self.keys, &mut self.scratch);
            shift += RADIX_BITS;
        }
    }

    /// (time, pixel index, polarity) of a key of the interval starting at `t0`.
    fn unpack(&self, key: u64, t0: u64) -> (u64, u32, Polarity) {
        let pixel = ((key >> 1) & ((1u64 << self.pixel_bits) - 1)) as u32;
        let polarity = if key & 1 == 1 {
            Polarity::On
        } else {
            Polarity::Off
        };
        (t0 + (key >> (self.pixel_bits + 1)), pixel, polarity)
    }
}

/// How far below the exact due value a pixel is scheduled, relative to the magnitudes
/// involved: far above f64 rounding (≈ 1e-16 relative), so a crossing is never judged late.
const DUE_MARGIN: f64 = 1e-9;

/// The leak value `g` at which a pixel at `level` with threshold `c`, leak phase `phase` and
/// log change `delta = L − L_init` (its key unchanged) reaches its next upward level:
/// `delta + c·(φ + g) ≥ (level + 1)·c` ⟺ `g ≥ level + 1 − φ − delta / c`, minus a margin.
fn due_g(level: i32, phase: f64, delta: f64, c: f64) -> f64 {
    let exact = f64::from(level) + 1.0 - phase - delta / c;
    exact - DUE_MARGIN * (1.0 + exact.abs() + (delta / c).abs())
}

/// With leak, the pixels ordered by the leak value `g` at which each may next cross upward with
/// its key unchanged. `g` grows with time (it is `leak_hz` times the time since the first
/// frame), so a frame at `g1` need judge only the pixels due by `g1` and those whose key
/// changed. Entries are never removed early: a pixel judged for another reason gets a new entry
/// and its old one is skipped as stale (its due value no longer matches).
#[derive(Clone, Default)]
struct LeakSchedule {
    /// Due value of each pixel's live entry.
    due: Vec<f64>,
    /// (due value's bits, pixel): non-negative f64 order as their bits do.
    heap: std::collections::BinaryHeap<std::cmp::Reverse<(u64, u32)>>,
}

impl LeakSchedule {
    fn new(due: impl Iterator<Item = f64>) -> Self {
        let due: Vec<f64> = due.collect();
        let heap = due
            .iter()
            .enumerate()
            .map(|(i, &g)| std::cmp::Reverse((g.max(0.0).to_bits(), i as u32)))
            .collect();
        Self { due, heap }
    }

    fn set(&mut self, i: usize, g: f64) {
        let g = g.max(0.0);
        self.due[i] = g;
        self.heap.push(std::cmp::Reverse((g.to_bits(), i as u32)));
    }

    /// The next pixel due by `g1` (its entry removed), skipping stale entries.
    fn pop_due(&mut self, g1: f64) -> Option<usize> {
        while let Some(&std::cmp::Reverse((bits, i))) = self.heap.peek() {
            if f64::from_bits(bits) > g1 {
                return None;
            }
            self.heap.pop();
            if self.due[i as usize].to_bits() == bits {
                return Some(i as usize);
            }
        }
        None
    }
}

/// One leaky frame's constants: judges a pixel exactly as the rule states.
struct PixelJudge<'a> {
    table: &'a [f64],
    thresholds: &'a [f64],
    phases: &'a [f64],
    g0: f64,
    g1: f64,
    at: &'a Interval,
}

impl PixelJudge<'_> {
    /// Pixel `i` has key `key` at the frame (its previous key still in `prev_keys`): records its
    /// crossings, its new level and key, and reschedules it.
    fn judge(&self, state: &mut State, i: usize, key: u32) {
        let (c, phase, l_init) = (self.thresholds[i], self.phases[i], state.l_init[i]);
        let delta = self.table[key as usize] - l_init;
        let d1 = delta + c * (phase + self.g1);
        let mut level = state.level[i];
        if d1 >= f64::from(level + 1) * c || d1 <= f64::from(level - 1) * c {
            let d0 = (self.table[state.prev_keys[i] as usize] - l_init) + c * (phase + self.g0);
            level = self.at.cross(
                i,
                d0,
                d1,
                c,
                level,
                &mut state.ready_at,
                &mut state.crossings,
            );
            state.level[i] = level;
        }
        state.prev_keys[i] = key;
        let due = due_g(level, phase, delta, c);
        // Judged early (inside the margin) without crossing: due again at the next frame.
        let due = if due <= self.g1 {
            self.g1.next_up()
        } else {
            due
        };
        state.leak.set(i, due);
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
