//! Shot noise: where the spurious events of one interval fall, and their sort.
//!
//! The rate of pixel i is `shot_noise_hz · (C / C_i) · (1 − b·I_i)`, as v2e's
//! (`emulator_utils.generate_shot_noise`): a pixel with a lower threshold is noisier in
//! proportion, and a brighter one quieter, `I_i = (Y_i + 20) / 275` the pixel's intensity on
//! v2e's scale (`Y_i` its luminance 0–255 at the end of the interval) and `b` the
//! `shot_noise_bright_drop` (v2e: 1 − `SHOT_NOISE_INTEN_FACTOR` = 0.75). Candidates are drawn
//! at the rate `shot_noise_hz · mean(C / C_i)` over the sensor, at a pixel drawn in proportion
//! to `C / C_i` (Walker's alias method), then kept with probability `1 − b·I_i` (thinning).
//! Each candidate uses two 64-bit draws whatever the terms: the pixel column and the alias coin
//! from the first, the time, the polarity and the thinning coin from the second, so the
//! uniform sensor (`C_i = C`, `b = 0`) draws exactly what it always did.

use rand::{Rng, RngCore};
use rand_chacha::ChaCha8Rng;

use crate::event::Polarity;

/// Radix digit width of the shot-event sort.
const RADIX_BITS: u32 = 11;

/// Walker alias table of the pixels' relative shot rates `C / C_i`.
#[derive(Clone, Debug)]
struct Alias {
    /// Probability (scaled to 2³²) that a column keeps its own pixel.
    keep: Vec<u64>,
    alias: Vec<u32>,
}

impl Alias {
    /// Vose's construction; deterministic for given weights.
    fn new(weights: &[f64]) -> Self {
        let n = weights.len();
        let total: f64 = weights.iter().sum();
        let mut scaled: Vec<f64> = weights.iter().map(|w| w * n as f64 / total).collect();
        let (mut small, mut large): (Vec<usize>, Vec<usize>) =
            (0..n).partition(|&i| scaled[i] < 1.0);
        let mut keep = vec![1u64 << 32; n];
        let mut alias: Vec<u32> = (0..n as u32).collect();
        while let (Some(s), Some(&l)) = (small.pop(), large.last()) {
            keep[s] = (scaled[s] * (1u64 << 32) as f64) as u64;
            alias[s] = l as u32;
            scaled[l] -= 1.0 - scaled[s];
            if scaled[l] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        Self { keep, alias }
    }
}

/// The per-pixel shot-noise rate map (uniform when both factors are off).
#[derive(Clone, Debug, Default)]
pub(super) struct ShotMap {
    alias: Option<Alias>,
    /// mean(C / C_i): the candidates' rate relative to `shot_noise_hz`.
    pub mean_weight: f64,
    /// b.
    bright_drop: f64,
}

impl ShotMap {
    /// The map for thresholds `c_i` around the nominal `c`.
    pub fn new(c: f64, thresholds: &[f64], bright_drop: f64) -> Self {
        let uniform = thresholds.iter().all(|&ci| ci == c);
        let (alias, mean_weight) = if uniform || thresholds.is_empty() {
            (None, 1.0)
        } else {
            let weights: Vec<f64> = thresholds.iter().map(|&ci| c / ci).collect();
            let mean = weights.iter().sum::<f64>() / weights.len() as f64;
            (Some(Alias::new(&weights)), mean)
        };
        Self {
            alias,
            mean_weight,
            bright_drop,
        }
    }
}

/// One interval's shot events as sortable keys `(t − t0, pixel, polarity)`, packed into a u64
/// (`t − t0` highest), sorted by an LSD radix sort: linear in the count, where a comparison
/// sort of the ≈ 15 000 events of a 10 ms interval at 5 Hz per pixel cost more than drawing
/// them.
#[derive(Clone, Default)]
pub(super) struct ShotDraws {
    pub keys: Vec<u64>,
    scratch: Vec<u64>,
    /// Bits of the pixel index field.
    pixel_bits: u32,
}

impl ShotDraws {
    /// Draws `count` candidates, each at a pixel of `pixels` (uniform or by `map`'s alias), a
    /// uniform integer time offset in `1..=dt` and a fair polarity, keeps each with `map`'s
    /// brightness probability (`luminance_keys` are the pixels' keys at the interval's end),
    /// and sorts them by (time, pixel, polarity).
    pub fn draw(
        &mut self,
        rng: &mut ChaCha8Rng,
        count: u64,
        pixels: u32,
        dt: u64,
        map: &ShotMap,
        luminance_keys: &[u32],
    ) {
        self.pixel_bits = 32 - pixels.saturating_sub(1).leading_zeros();
        let time_bits = 64 - dt.leading_zeros();
        let bits = time_bits + self.pixel_bits + 1;
        for _ in 0..count {
            let (a, b) = (rng.next_u64(), rng.next_u64());
            // Multiply-shift: a uniform value below the bound from 32 random bits (bias below
            // bound / 2³², negligible for a sensor's pixels); times beyond 32 bits draw exactly.
            let column = ((a >> 32) * u64::from(pixels)) >> 32;
            let pixel = match &map.alias {
                Some(alias) if (a & 0xFFFF_FFFF) >= alias.keep[column as usize] => {
                    u64::from(alias.alias[column as usize])
                }
                _ => column,
            };
            if map.bright_drop > 0.0 {
                let y = f64::from(luminance_keys[pixel as usize]) / 1000.0;
                let keep = 1.0 - map.bright_drop * (y + 20.0) / 275.0;
                let coin = ((b >> 1) & 0x7FFF_FFFF) as f64 / f64::from(1u32 << 31);
                if coin >= keep {
                    continue;
                }
            }
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
    pub fn unpack(&self, key: u64, t0: u64) -> (u64, u32, Polarity) {
        let pixel = ((key >> 1) & ((1u64 << self.pixel_bits) - 1)) as u32;
        let polarity = if key & 1 == 1 {
            Polarity::On
        } else {
            Polarity::Off
        };
        (t0 + (key >> (self.pixel_bits + 1)), pixel, polarity)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn alias_draws_in_proportion_to_the_weights() {
        let weights = [1.0, 2.0, 0.5, 4.0, 0.5];
        let alias = Alias::new(&weights);
        let total: f64 = weights.iter().sum();
        // Exact probability of each pixel: sum over columns of the kept and aliased shares.
        let n = weights.len() as f64;
        let mut p = [0.0; 5];
        for col in 0..weights.len() {
            let keep = alias.keep[col] as f64 / (1u64 << 32) as f64;
            p[col] += keep / n;
            p[alias.alias[col] as usize] += (1.0 - keep) / n;
        }
        for (i, w) in weights.iter().enumerate() {
            assert!(
                (p[i] - w / total).abs() < 1e-9,
                "{i}: {} vs {}",
                p[i],
                w / total
            );
        }
    }
}
