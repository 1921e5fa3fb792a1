//! A seeded, v2e-style noisy sensor: [`EventNoise`] and the [`NoisyConverter`].
//!
//! The ideal converter ([`crate::Converter`]) models a perfect pixel. Real DVS pixels are not
//! perfect; to study decoding under sensor noise this module adds the non-idealities of the v2e
//! model (Y. Hu, S.-C. Liu, T. Delbruck, "v2e: From Video Frames to Realistic DVS Events",
//! CVPRW 2021; SensorsINI/v2e), on top of *exactly* the ideal model's rules (see the crate
//! docs). Every term is off by default:
//!
//! | term | field | unit | effect |
//! | --- | --- | --- | --- |
//! | lin-log curve | `linlog_dn` | luminance 0–255 | below this luminance the log curve is linear, `L = Y·ln(Y₀)/Y₀` (v2e: 20); 0 = `ln(max(Y, 1))` |
//! | photoreceptor bandwidth | `cutoff_hz` | Hz | first-order low-pass of `L` whose cutoff scales with intensity: `ε = min(I·dt·2π·f_c, 1)`, `I = (Y + 20)/275` (v2e's), per frame |
//! | threshold mismatch | `threshold_sigma` | log intensity | pixel i has its own threshold `C_i = max(C + σ·z_i, min(0.01, C))`, `z_i ~ N(0, 1)`, drawn once |
//! | refractory period | `refractory_ns` | ns | a crossing less than this after the pixel's previous *emitted* crossing is not emitted; the level still follows the input |
//! | leak | `leak_hz` | Hz | the reference drifts down by `leak_hz·C_i` per second, so a static pixel emits ON events at `leak_hz` |
//! | leak-rate spread | `leak_spread_decades` | decades | pixel i leaks at `leak_hz·10^(σ·z_i)` (v2e's `noise_rate_cov_decades`) |
//! | leak jitter | `leak_jitter` | fraction | each pixel's leak rate is redrawn every nominal leak period, relative σ (v2e's `leak_jitter_fraction`) |
//! | shot noise | `shot_noise_hz` | Hz per pixel | spurious events, Poisson per pixel at `shot_noise_hz·C/C_i·(1 − b·I)`, ON/OFF with equal probability; the reference does not move |
//! | shot noise in bright pixels | `shot_noise_bright_drop` | fraction | b above (v2e: 0.75, i.e. 0.25× the rate at white) |
//! | hot pixels | `hot_pixels`, `hot_pixel_hz` | count, Hz | that many distinct pixels each add ON events periodically at `hot_pixel_hz` |
//!
//! # Exact rules
//!
//! With the integer level `n`, the crossing test and the interpolated crossing time exactly
//! those of the ideal converter, pixel i uses
//!
//! * `L` from the lin-log curve when `linlog_dn > 0` (one table per converter, monotone);
//! * with `cutoff_hz > 0`, `P` in place of `L`: `P` starts at the first frame's `L` and each
//!   frame sets `P ← P + ε·(L − P)`, `ε = min(I·(dt·1e-9)·2π·cutoff_hz, 1)` with `I` of the new
//!   frame's luminance; `P = L` exactly when `ε = 1` or `|L − P| ≤ LOWPASS_SETTLED`;
//! * `C_i` in place of `C` in every comparison and interpolation (`f64::from(n ± 1) * C_i`);
//! * `d(t) = (P(t) − P_init) + C_i·Λ_i(g(t))` in place of `d = L − L_init`, with
//!   `g(t) = leak_hz · ((t − t_first) as f64 · 1e-9)` (one value per frame) and `Λ_i` the
//!   pixel's leak function (see [`leak`]: phase, spread and jitter; `Λ_i(g) = φ_i + g` without
//!   spread and jitter). `d` is interpolated linearly between frames. With `leak_hz = 0` there
//!   is no leak term at all: `d = P − P_init`;
//! * refractory filter: a crossing at `t` is emitted only if `t ≥ t_emit + refractory_ns`,
//!   `t_emit` the time of the pixel's previous emitted crossing (always emitted if none);
//!   filtered crossings still move the level;
//! * shot noise: see the `shot` module;
//! * hot pixel j (distinct pixels chosen by the seed, phase `ψ_j ~ U[0, 1)`): ON events at
//!   `t_first + max(1, ceil((k + ψ_j) · 1e9 / hot_pixel_hz))`, k = 0, 1, …, each in the
//!   interval containing it.
//!
//! Events of one interval are sorted by (time, pixel index, order), where order is the crossing
//! order for threshold crossings, which come before a hot pixel's event, which comes before
//! shot events (OFF before ON, then draw order). Shot and hot-pixel events are not subject to
//! the refractory period and never move a reference (v2e moves it, but the event it would
//! cause is cancelled by its own rounding; its measured rates match a fixed reference).
//!
//! # Simplifications against v2e
//!
//! One threshold per pixel for both polarities (no separate ON/OFF mismatch), no threshold
//! drift over time, no photoreceptor noise (v2e's optional alternative to shot noise), hot
//! pixels periodic rather than random, no 1e-8 rounding of the lin-log value, and the leak phase
//! random from the start (v2e starts every pixel at phase 0: no leak events for ≈ 1/leak_hz).
//! `tests/v2e.rs` compares the statistics with v2e's own output.
//!
//! # Seeds
//!
//! Every random draw comes from `ChaCha8Rng::seed_from_u64(seed)` with one stream per term
//! (`set_stream`: 1 threshold map, 2 leak phases, 3 shot noise, 4 hot pixels, 5 leak-rate
//! spread) or from a counter-based hash of the seed (leak jitter), so changing one term never
//! changes another's draws. The same seed, configuration and frames give the same events, byte
//! for byte; the shot-noise stream advances interval by interval, so it also depends on the
//! frame stamps.
//!
//! # Speed
//!
//! Without leak and low-pass a pixel's input can only cross a level when its luminance key
//! changes, so the converter keeps the ideal converter's per-pixel key bounds (with `C_i`) and
//! its vectorised scan, and [`NoisyConverter::push_region`] skips unchanged pixels exactly.
//! With leak every pixel's `d` grows every frame, but a pixel whose input did not change can
//! only cross upward, at a leak value `g` known in advance: a schedule ordered by that value
//! hands each frame the pixels due by then; with the low-pass, the pixels whose `P` has not
//! settled are judged every frame. Each judged pixel follows the exact rule, so the events are
//! the same as judging every pixel every frame (the scalar reference in `tests/noise.rs` checks
//! it); the cost is the changed and settling pixels plus about one judgement per leak event.

mod converter;
pub mod leak;
mod schedule;
mod shot;
mod state;

pub use converter::NoisyConverter;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::error::NoiseError;

/// Largest accepted rate of any noise term (leak, shot noise, hot pixels), Hz per pixel: real
/// sensors are well below; the bound catches unit slips before they fill memory with events.
pub const MAX_NOISE_RATE_HZ: f64 = 1e4;

/// Largest accepted photoreceptor cutoff, Hz (a frame rate beyond any renderer's).
pub const MAX_CUTOFF_HZ: f64 = 1e6;

/// |L − P| below which the low-passed log intensity is taken to have reached its input, log
/// intensity: 0.1 % in intensity, 0.5 % of v2e's threshold, so the photoreceptor has reached
/// its input for every purpose of the model. The snap lets a pixel return exactly to a former
/// value in finite time (≈ 8 time constants after a full-range step), as the ideal sensor
/// does; an exponential that never arrives would hold back a pixel's last event indefinitely
/// (with 1e-9 it came ≈ 21 time constants late, outside v2e's 0.6 s window: `tests/v2e.rs`).
pub const LOWPASS_SETTLED: f64 = 1e-3;

/// Smallest threshold a pixel's mismatch may draw, log intensity (v2e clamps its per-pixel
/// thresholds at 0.01 too): a pixel that low emits ≈ 20 events per threshold-0.2 step, and one
/// lower would dominate every count. A nominal threshold below it is kept as is.
pub const MIN_PIXEL_THRESHOLD: f64 = 0.01;

/// Sensor non-idealities of the v2e model; all zero = the ideal sensor.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct EventNoise {
    /// Per-pixel contrast-threshold mismatch: each pixel's threshold `C_i ~ N(C, σ²)`, σ in
    /// log-intensity units (drawn once per pixel from the seed, clamped to ≥ [`MIN_PIXEL_THRESHOLD`]).
    pub threshold_sigma: f64,
    /// Refractory period, ns: after a pixel emits, its further crossings within this time still
    /// move its reference level (it follows the input) but emit nothing.
    pub refractory_ns: u64,
    /// Leak rate, Hz: the reference drifts down by `leak_hz·C_i` per second, so a static pixel
    /// emits ON events at ≈ `leak_hz` (random initial phase per pixel).
    pub leak_hz: f64,
    /// Spread of the leak rate across pixels, decades (σ of `log10` of each pixel's rate).
    pub leak_spread_decades: f64,
    /// Relative σ of each pixel's leak rate, redrawn every nominal leak period.
    pub leak_jitter: f64,
    /// Shot noise, Hz per pixel (at the nominal threshold, before the brightness factor): a
    /// Poisson process of spurious events per pixel, polarity ON/OFF with equal probability,
    /// not changing the reference.
    pub shot_noise_hz: f64,
    /// Fraction b by which shot noise drops at white: the rate is scaled by `1 − b·I`,
    /// `I = (Y + 20)/275` (0 = independent of intensity; v2e 0.75).
    pub shot_noise_bright_drop: f64,
    /// Photoreceptor cutoff at white, Hz; the cutoff scales with intensity `I` (0 = infinite
    /// bandwidth).
    pub cutoff_hz: f64,
    /// Luminance below which the log curve is linear (v2e 20; 0 = `ln(max(Y, 1))`).
    pub linlog_dn: f64,
    /// Number of hot pixels (chosen by seed, distinct), each emitting ON events periodically at
    /// `hot_pixel_hz` with a random phase.
    pub hot_pixels: u32,
    /// Rate of each hot pixel, Hz.
    pub hot_pixel_hz: f64,
    /// Seed of every random draw (threshold map, leak phases, shot noise, hot pixels).
    pub seed: u64,
}

impl EventNoise {
    /// True when no term is active (the seed is irrelevant then): the ideal sensor. A term
    /// that only shapes another (leak spread and jitter without leak, the brightness factor
    /// without shot noise) is not active on its own.
    pub fn is_ideal(&self) -> bool {
        self.threshold_sigma == 0.0
            && self.refractory_ns == 0
            && self.leak_hz == 0.0
            && self.shot_noise_hz == 0.0
            && self.cutoff_hz == 0.0
            && self.linlog_dn == 0.0
            && self.hot_pixels == 0
    }

    /// Checks every field: finite and non-negative, rates at most [`MAX_NOISE_RATE_HZ`],
    /// fractions at most 1, `linlog_dn` 0 or in 1–255, `hot_pixel_hz > 0` when there are hot
    /// pixels. The error names the field and its value. (Whether the hot pixels fit the sensor
    /// is checked by [`NoisyConverter::new`].)
    pub fn validate(&self) -> Result<(), NoiseError> {
        let fields = [
            ("threshold_sigma", self.threshold_sigma, f64::INFINITY),
            ("leak_hz", self.leak_hz, MAX_NOISE_RATE_HZ),
            ("leak_spread_decades", self.leak_spread_decades, 3.0),
            ("leak_jitter", self.leak_jitter, 1.0),
            ("shot_noise_hz", self.shot_noise_hz, MAX_NOISE_RATE_HZ),
            ("shot_noise_bright_drop", self.shot_noise_bright_drop, 1.0),
            ("cutoff_hz", self.cutoff_hz, MAX_CUTOFF_HZ),
            ("linlog_dn", self.linlog_dn, 255.0),
            ("hot_pixel_hz", self.hot_pixel_hz, MAX_NOISE_RATE_HZ),
        ];
        for (field, value, max) in fields {
            if !(value.is_finite() && value >= 0.0) {
                return Err(NoiseError::NotFiniteNonNegative { field, value });
            }
            if value > max {
                return Err(NoiseError::TooLarge { field, value, max });
            }
        }
        if self.linlog_dn > 0.0 && self.linlog_dn < 1.0 {
            return Err(NoiseError::LinLogBelowOne(self.linlog_dn));
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
const STREAM_LEAK_SPREAD: u64 = 5;

fn rng_stream(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    rng
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;

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
                cutoff_hz: 100.0,
                ..base
            },
            EventNoise {
                linlog_dn: 20.0,
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
    fn shaping_terms_alone_are_ideal() {
        let shaped = EventNoise {
            leak_spread_decades: 0.1,
            leak_jitter: 0.1,
            shot_noise_bright_drop: 0.75,
            ..EventNoise::default()
        };
        assert!(shaped.is_ideal());
        assert_eq!(shaped.validate(), Ok(()));
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
