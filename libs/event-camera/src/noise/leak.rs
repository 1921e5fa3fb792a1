//! The leak of a noisy pixel (module `schedule` finds the pixels it is about to fire).
//!
//! Pixel i's reference drifts down by `C_i·Λ_i(g)`, `g = leak_hz·(t − t_first)` (seconds), with
//!
//! `Λ_i(g) = φ_i + s_i·J_i(g)`,
//!
//! * `φ_i ~ U[0, 1)` the leak phase (a sensor that has been on for a while is in a random phase;
//!   v2e starts every pixel at 0, so its first leak events come after ≈ 1/leak_hz);
//! * `s_i = 10^(σ_dec·z_i)`, `z_i ~ N(0, 1)`, the pixel's rate relative to `leak_hz`
//!   (v2e's `noise_rate_cov_decades`; `s_i = 1` when σ_dec = 0);
//! * `J_i(g)` piecewise linear with slope `w_{i,m} = max(1 − j·ζ_{i,m}, MIN_LEAK_WEIGHT)` on
//!   `[m, m + 1)`, `ζ_{i,m} ~ N(0, 1)` drawn from a counter-based hash of (seed, i, m), so the
//!   rate of every pixel is redrawn once per nominal leak period (`1/leak_hz`): the leak
//!   interval jitters by ≈ j relative, which is what v2e's `leak_jitter_fraction` is documented
//!   to do ("jitter of leak noise events relative to the interval"; v2e redraws it every frame,
//!   where it averages out to ≈ j·√(leak_hz·dt)). `J_i(g) = g` when j = 0.
//!
//! `J_i` is summed from m = 0 upwards, always in that order (a cache only skips repeated
//! work), so every evaluation of the same `g` gives the same bits.

use rand::Rng;
use rand_distr::StandardNormal;

use super::{EventNoise, STREAM_LEAK, STREAM_LEAK_SPREAD, rng_stream};
use crate::prefetch::prefetch;

/// Smallest leak slope of one period: keeps `J_i` strictly increasing (so invertible) when a
/// jitter draw exceeds `1/j` standard deviations.
pub const MIN_LEAK_WEIGHT: f64 = 0.05;

/// How many leak periods a due-time search walks before it settles for an early estimate
/// (the pixel is then judged at that time and rescheduled: never late, only re-judged).
const MAX_WALK: u32 = 64;

/// How far below the exact due value a pixel is scheduled, relative to the magnitudes
/// involved: far above f64 rounding (≈ 1e-16 relative), so a crossing is never judged late.
const DUE_MARGIN: f64 = 1e-9;

/// The per-pixel leak terms (empty vectors when the leak is off).
#[derive(Clone, Debug, Default)]
pub(super) struct LeakModel {
    /// φ_i.
    pub phases: Vec<f64>,
    /// s_i (empty: every pixel 1).
    pub scales: Vec<f64>,
    /// j.
    pub jitter: f64,
    pub seed: u64,
}

/// Per-pixel `(m, J_i(m), w_{i,m})` of the last leak period reached, to skip re-summing from 0
/// and re-drawing the period's slope.
#[derive(Clone, Debug, Default)]
pub(super) struct JitterCache {
    m: Vec<u32>,
    at_m: Vec<f64>,
    w_m: Vec<f64>,
}

impl LeakModel {
    pub fn new(noise: &EventNoise, pixels: usize) -> Self {
        if noise.leak_hz <= 0.0 {
            return Self::default();
        }
        let mut rng = rng_stream(noise.seed, STREAM_LEAK);
        let phases = (0..pixels).map(|_| rng.r#gen::<f64>()).collect();
        let scales = if noise.leak_spread_decades > 0.0 {
            let mut rng = rng_stream(noise.seed, STREAM_LEAK_SPREAD);
            (0..pixels)
                .map(|_| {
                    let z: f64 = rng.sample(StandardNormal);
                    10f64.powf(noise.leak_spread_decades * z)
                })
                .collect()
        } else {
            Vec::new()
        };
        Self {
            phases,
            scales,
            jitter: noise.leak_jitter,
            seed: noise.seed,
        }
    }

    pub fn cache(&self) -> JitterCache {
        if self.jitter > 0.0 {
            JitterCache {
                m: vec![0; self.phases.len()],
                at_m: vec![0.0; self.phases.len()],
                w_m: (0..self.phases.len()).map(|i| self.weight(i, 0)).collect(),
            }
        } else {
            JitterCache::default()
        }
    }

    /// Asks for pixel i's leak terms and cached jitter sum ahead of judging it.
    #[inline(always)]
    pub fn prefetch(&self, cache: &JitterCache, i: usize) {
        prefetch(&self.phases, i);
        prefetch(&self.scales, i);
        prefetch(&cache.m, i);
        prefetch(&cache.at_m, i);
        prefetch(&cache.w_m, i);
    }

    pub fn scale(&self, i: usize) -> f64 {
        self.scales.get(i).copied().unwrap_or(1.0)
    }

    /// `w_{i,m}`: the slope of `J_i` in leak period m.
    pub fn weight(&self, i: usize, m: u32) -> f64 {
        if self.jitter == 0.0 {
            return 1.0;
        }
        (1.0 - self.jitter * hashed_normal(self.seed, i as u64, u64::from(m))).max(MIN_LEAK_WEIGHT)
    }

    /// `Λ_i(g)`; with `store`, the cache moves to `⌊g⌋` (only ever forwards: `g` must not be
    /// below a value stored before).
    pub fn at(&self, cache: &mut JitterCache, i: usize, g: f64, store: bool) -> f64 {
        let j = if self.jitter == 0.0 {
            g
        } else {
            let target = g.floor() as u32;
            let (mut m, mut p, mut w) = match cache.m.get(i) {
                Some(&m) if m <= target => (m, cache.at_m[i], cache.w_m[i]),
                _ => (0, 0.0, self.weight(i, 0)),
            };
            while m < target {
                p += w;
                m += 1;
                w = self.weight(i, m);
            }
            if store && i < cache.m.len() {
                (cache.m[i], cache.at_m[i], cache.w_m[i]) = (m, p, w);
            }
            p + w * (g - f64::from(m))
        };
        self.phases[i] + self.scale(i) * j
    }

    /// The leak value `g` at which pixel i, at `level` with threshold `c` and log change
    /// `delta` (its input unchanged), reaches its next upward level:
    /// `delta + c·Λ_i(g) ≥ (level + 1)·c`, minus a margin (never late; early is re-judged).
    pub fn due(&self, cache: &JitterCache, i: usize, level: i32, delta: f64, c: f64) -> f64 {
        let lambda = f64::from(level) + 1.0 - delta / c;
        let (phase, scale) = (self.phases[i], self.scale(i));
        if self.jitter == 0.0 && self.scales.is_empty() {
            let exact = lambda - phase;
            return exact - DUE_MARGIN * (1.0 + exact.abs() + (delta / c).abs());
        }
        let t = (lambda - phase) / scale;
        let exact = if self.jitter == 0.0 {
            t
        } else {
            // The cache holds the slope of its own period: the same bits `weight` would give,
            // without the hash and Box–Muller of a fresh draw.
            let (mut m, mut p, mut cached) = match (cache.m.get(i), cache.at_m.get(i)) {
                (Some(&m), Some(&p)) => (m, p, cache.w_m.get(i).copied()),
                _ => (0, 0.0, None),
            };
            let mut found = None;
            for _ in 0..MAX_WALK {
                let w = cached.take().unwrap_or_else(|| self.weight(i, m));
                if p + w > t {
                    found = Some(f64::from(m) + (t - p).max(0.0) / w);
                    break;
                }
                p += w;
                m += 1;
            }
            found.unwrap_or(f64::from(m))
        };
        exact - DUE_MARGIN * (1.0 + exact.abs() + t.abs() + (delta / c).abs())
    }
}

/// A standard normal variate from a counter-based hash of `(seed, a, b)` (SplitMix64 finaliser,
/// Box–Muller): order-independent, so a pixel's draws do not depend on when it is judged.
pub fn hashed_normal(seed: u64, a: u64, b: u64) -> f64 {
    let h1 =
        mix(seed ^ mix(a.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ mix(b ^ 0xD1B5_4A32_D192_ED03)));
    let h2 = mix(h1 ^ 0x94D0_49BB_1331_11EB);
    // u1 in (0, 1], u2 in [0, 1): 53-bit mantissas.
    let u1 = ((h1 >> 11) + 1) as f64 / (1u64 << 53) as f64;
    let u2 = (h2 >> 11) as f64 / (1u64 << 53) as f64;
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hashed_normals_are_standard_and_repeatable() {
        let n = 200_000u64;
        let z: Vec<f64> = (0..n).map(|k| hashed_normal(7, k % 977, k / 977)).collect();
        let mean = z.iter().sum::<f64>() / n as f64;
        let var = z.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(mean.abs() < 0.01, "{mean}");
        assert!((var - 1.0).abs() < 0.02, "{var}");
        assert_eq!(
            hashed_normal(7, 3, 4).to_bits(),
            hashed_normal(7, 3, 4).to_bits()
        );
        assert_ne!(hashed_normal(7, 3, 4), hashed_normal(8, 3, 4));
        assert_ne!(hashed_normal(7, 3, 4), hashed_normal(7, 4, 3));
    }

    #[test]
    fn cached_and_fresh_evaluations_agree_bit_for_bit() {
        let noise = EventNoise {
            leak_hz: 1.0,
            leak_jitter: 0.3,
            leak_spread_decades: 0.2,
            seed: 5,
            ..EventNoise::default()
        };
        let model = LeakModel::new(&noise, 4);
        let mut cache = model.cache();
        for k in 0..400 {
            let g = f64::from(k) * 0.037;
            let fresh = model.at(&mut model.cache(), 2, g, false);
            assert_eq!(
                model.at(&mut cache, 2, g, true).to_bits(),
                fresh.to_bits(),
                "{g}"
            );
        }
    }

    #[test]
    fn due_is_never_after_the_crossing() {
        let noise = EventNoise {
            leak_hz: 1.0,
            leak_jitter: 0.5,
            leak_spread_decades: 0.3,
            seed: 11,
            ..EventNoise::default()
        };
        let model = LeakModel::new(&noise, 8);
        let cache = model.cache();
        for i in 0..8 {
            for level in 0..5 {
                let (delta, c) = (0.01 * f64::from(level), 0.2);
                let g = model.due(&cache, i, level, delta, c);
                let at = |g: f64| delta + c * model.at(&mut model.cache(), i, g, false);
                // Just before the due value: below the level; a little after: at or above it.
                assert!(at(g) < f64::from(level + 1) * c + 1e-12, "{i} {level}");
                assert!(
                    at(g + 1e-6) >= f64::from(level + 1) * c - 1e-9,
                    "{i} {level}"
                );
            }
        }
    }
}
