//! The RGB sensor's perturbations, applied to rendered frames before the receiver sees them.
//!
//! In order: motion blur (the mean of the last `blur_renders` renders, 10 ms apart, as a longer
//! exposure integrates), illumination/exposure (a gain on every value) and read noise (an
//! Gaussian per pixel and channel, σ in grey levels, added in whole grey levels), then clamping
//! to 0–255. With the defaults the frame is passed through byte for byte.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// The RGB camera's non-idealities; the default is the ideal sensor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RgbNoise {
    /// Read noise σ, grey levels (0–255 scale), per pixel and channel.
    pub read_noise_grey: f64,
    /// Illumination/exposure gain on every value (1 = as rendered).
    pub exposure_scale: f64,
    /// Renders averaged into one frame (1 = no blur; each render spans 10 ms).
    pub blur_renders: u32,
}

impl Default for RgbNoise {
    fn default() -> Self {
        Self {
            read_noise_grey: 0.0,
            exposure_scale: 1.0,
            blur_renders: 1,
        }
    }
}

impl RgbNoise {
    /// True when frames pass through unchanged.
    pub fn is_ideal(&self) -> bool {
        *self == Self::default()
    }

    /// The sensor of one observer in one trial, drawing its read noise from `rng`.
    pub fn sensor(&self, rng: &mut ChaCha8Rng) -> RgbSensor {
        RgbSensor {
            noise: *self,
            normal: Normal::new(0.0, self.read_noise_grey)
                .ok()
                .filter(|_| self.read_noise_grey > 0.0),
            pool: Vec::new(),
            rng: ChaCha8Rng::seed_from_u64(rng.r#gen()),
            luts: Vec::new(),
        }
    }
}

/// The read-noise pool holds this many frames' worth of draws.
const POOL_FRAMES: usize = 4;

/// One RGB sensor's perturbation state: the exposure/blur lookup tables and the read-noise
/// pool. Read noise is added in whole grey levels (a rounded Gaussian). The sensor draws a pool
/// of four frames' worth of independent values once, then each frame adds a window of it that
/// starts at a fresh random offset: every value of a frame is an independent draw, and a frame
/// costs one vectorised add, not a Gaussian draw per value (which cost more than the receiver).
/// Two frames reuse draws only as a copy shifted by a random offset of whole pixels.
#[derive(Debug, Clone)]
pub struct RgbSensor {
    noise: RgbNoise,
    normal: Option<Normal<f64>>,
    pool: Vec<i16>,
    rng: ChaCha8Rng,
    /// `luts[k-1][sum]`: the exposed value of the sum of `k` renders.
    luts: Vec<Vec<u8>>,
}

impl RgbSensor {
    /// The frame the sensor delivers from `renders` (oldest first, the current one last; fewer
    /// than `blur_renders` at the start of a flight). All renders have the same length.
    pub fn apply(&mut self, renders: &[&[u8]]) -> Vec<u8> {
        let Some(&current) = renders.last() else {
            return Vec::new();
        };
        if self.noise.is_ideal() {
            return current.to_vec();
        }
        let k = renders.len().min(self.noise.blur_renders.max(1) as usize);
        let used = &renders[renders.len() - k..];
        while self.luts.len() < k {
            let n = self.luts.len() + 1;
            let gain = self.noise.exposure_scale / n as f64;
            self.luts.push(
                (0..=255 * n)
                    .map(|s| (s as f64 * gain).round().clamp(0.0, 255.0) as u8)
                    .collect(),
            );
        }
        let lut = &self.luts[k - 1];
        let mut out: Vec<u8> = if k == 1 {
            current.iter().map(|&v| lut[usize::from(v)]).collect()
        } else {
            (0..current.len())
                .map(|i| lut[used.iter().map(|r| usize::from(r[i])).sum::<usize>()])
                .collect()
        };
        if let Some(normal) = self.normal {
            let len = out.len();
            if self.pool.len() != POOL_FRAMES * len {
                let rng = &mut self.rng;
                self.pool = (0..POOL_FRAMES * len)
                    .map(|_| normal.sample(rng).round().clamp(-255.0, 255.0) as i16)
                    .collect();
            }
            let start = self.rng.gen_range(0..=(POOL_FRAMES - 1) * len);
            for (v, &n) in out.iter_mut().zip(&self.pool[start..start + len]) {
                *v = (i16::from(*v) + n).clamp(0, 255) as u8;
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use rand::SeedableRng;

    use super::*;

    fn rng(seed: u64) -> ChaCha8Rng {
        ChaCha8Rng::seed_from_u64(seed)
    }

    #[test]
    fn ideal_passes_the_current_render_through() {
        let a = vec![1u8, 2, 3];
        let b = vec![200u8, 100, 0];
        let out = RgbNoise::default().sensor(&mut rng(1)).apply(&[&a, &b]);
        assert_eq!(out, b);
    }

    #[test]
    fn read_noise_has_the_configured_spread() {
        let flat = vec![128u8; 300_000];
        let noise = RgbNoise {
            read_noise_grey: 4.0,
            ..RgbNoise::default()
        };
        let out = noise.sensor(&mut rng(7)).apply(&[&flat]);
        let n = out.len() as f64;
        let mean = out.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
        let var = out
            .iter()
            .map(|&v| (f64::from(v) - mean).powi(2))
            .sum::<f64>()
            / (n - 1.0);
        // Rounding adds 1/12 grey² of variance.
        let want = 16.0 + 1.0 / 12.0;
        assert!((mean - 128.0).abs() < 0.05, "mean {mean}");
        assert!((var / want - 1.0).abs() < 0.02, "variance {var} vs {want}");
        assert_ne!(out, noise.sensor(&mut rng(8)).apply(&[&flat]));
        assert_eq!(out, noise.sensor(&mut rng(7)).apply(&[&flat]));
    }

    #[test]
    fn successive_frames_draw_fresh_noise() {
        let flat = vec![128u8; 300_000];
        let mut sensor = RgbNoise {
            read_noise_grey: 4.0,
            ..RgbNoise::default()
        }
        .sensor(&mut rng(9));
        let (a, b) = (sensor.apply(&[&flat]), sensor.apply(&[&flat]));
        // Independent frames: the difference has twice the variance of one frame's noise.
        let n = a.len() as f64;
        let var = a
            .iter()
            .zip(&b)
            .map(|(&x, &y)| (f64::from(x) - f64::from(y)).powi(2))
            .sum::<f64>()
            / n;
        let want = 2.0 * (16.0 + 1.0 / 12.0);
        assert!(
            (var / want - 1.0).abs() < 0.03,
            "variance of the difference {var} vs {want}"
        );
    }

    #[test]
    fn exposure_scales_and_clamps() {
        let f = vec![0u8, 10, 100, 200];
        let dim = RgbNoise {
            exposure_scale: 0.5,
            ..RgbNoise::default()
        };
        assert_eq!(dim.sensor(&mut rng(1)).apply(&[&f]), vec![0, 5, 50, 100]);
        let bright = RgbNoise {
            exposure_scale: 2.0,
            ..RgbNoise::default()
        };
        assert_eq!(
            bright.sensor(&mut rng(1)).apply(&[&f]),
            vec![0, 20, 200, 255]
        );
    }

    #[test]
    fn blur_averages_the_last_renders() {
        let (a, b, c) = (vec![0u8, 90], vec![30u8, 60], vec![60u8, 30]);
        let blur = RgbNoise {
            blur_renders: 2,
            ..RgbNoise::default()
        };
        assert_eq!(blur.sensor(&mut rng(1)).apply(&[&a, &b, &c]), vec![45, 45]);
        // At the start of a flight fewer renders exist: average what there is.
        assert_eq!(blur.sensor(&mut rng(1)).apply(&[&a]), a);
    }
}
