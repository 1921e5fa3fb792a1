//! The RGB sensor's perturbations, applied to rendered frames before the receiver sees them.
//!
//! In order: motion blur (the mean of the last `blur_renders` renders, 10 ms apart, as a longer
//! exposure integrates), illumination/exposure (a gain on every value) and read noise (an
//! Gaussian per pixel and channel, σ in grey levels, added in whole grey levels), then clamping
//! to 0–255. With the defaults the frame is passed through byte for byte.
//!
//! Under a modelled light level (`lux > 0`, see [`crate::light`]) the exposed value then goes
//! through the photon model: each value is drawn from the distribution of
//! `gain · (Poisson(electrons) + N(0, read noise))`, rounded and clamped, by a per-value
//! quantile table (1 024 quantiles: probabilities resolved to 1/1 024) indexed by a pool of
//! uniform draws, as the read-noise pool does.

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
    /// Scene illuminance, lx (0: light not modelled; see [`crate::light`]).
    pub lux: f64,
}

impl Default for RgbNoise {
    fn default() -> Self {
        Self {
            read_noise_grey: 0.0,
            exposure_scale: 1.0,
            blur_renders: 1,
            lux: 0.0,
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
            photon: (self.lux > 0.0).then(|| PhotonTable::new(self.lux)),
            uniform_pool: Vec::new(),
        }
    }
}

/// Quantiles per value of the grey level the photon model delivers.
const QUANTILES: usize = 1024;

/// `quantiles[v][j]`: the grey level at probability `(j + 0.5) / QUANTILES` for exposed value v.
#[derive(Debug, Clone)]
struct PhotonTable {
    quantiles: Vec<[u8; QUANTILES]>,
}

impl PhotonTable {
    fn new(lux: f64) -> Self {
        let camera = crate::light::RGB_CAMERA;
        let exposure = camera.exposure(lux);
        let k = exposure.gain_grey_per_e;
        let sigma = camera.read_noise_e * k;
        let quantiles = (0..=255u32)
            .map(|v| {
                let lambda = exposure.white_e * f64::from(v) / 255.0;
                let pmf = grey_pmf(lambda, k, sigma);
                let mut q = [0u8; QUANTILES];
                let (mut g, mut cdf) = (0usize, pmf[0]);
                for (j, slot) in q.iter_mut().enumerate() {
                    let p = (j as f64 + 0.5) / QUANTILES as f64;
                    while cdf < p && g < 255 {
                        g += 1;
                        cdf += pmf[g];
                    }
                    *slot = g as u8;
                }
                q
            })
            .collect();
        Self { quantiles }
    }
}

/// Distribution over grey levels 0–255 of `round(k·(n + r))`, n ~ Poisson(λ), r ~ N(0, σ/k),
/// clamped (σ is the read noise in grey levels).
fn grey_pmf(lambda: f64, k: f64, sigma: f64) -> [f64; 256] {
    let mut pmf = [0.0; 256];
    let spread = 10.0 * lambda.sqrt() + 10.0;
    let (lo, hi) = (
        (lambda - spread).max(0.0).floor() as u64,
        (lambda + spread).ceil() as u64,
    );
    for n in lo..=hi {
        let p_n = poisson_pmf(lambda, n);
        if p_n < 1e-12 {
            continue;
        }
        let mean = k * n as f64;
        if sigma <= 0.0 {
            pmf[mean.round().clamp(0.0, 255.0) as usize] += p_n;
            continue;
        }
        let below = |g: f64| normal_cdf((g - mean) / sigma);
        let g_lo = (mean - 8.0 * sigma).floor().max(0.0) as usize;
        let g_hi = ((mean + 8.0 * sigma).ceil() as usize).min(255);
        for g in g_lo..=g_hi {
            let lower = if g == 0 { 0.0 } else { below(g as f64 - 0.5) };
            let upper = if g == 255 { 1.0 } else { below(g as f64 + 0.5) };
            pmf[g] += p_n * (upper - lower);
        }
        if g_lo > 0 {
            pmf[0] += p_n * below(g_lo as f64 - 0.5);
        }
        if g_hi < 255 {
            pmf[255] += p_n * (1.0 - below(g_hi as f64 + 0.5));
        }
    }
    pmf
}

/// Poisson(λ) probability of n, through `ln n!` (exact below 20, Stirling's series above).
fn poisson_pmf(lambda: f64, n: u64) -> f64 {
    if lambda == 0.0 {
        return if n == 0 { 1.0 } else { 0.0 };
    }
    let ln_fact = if n < 20 {
        (1..=n).map(|i| (i as f64).ln()).sum::<f64>()
    } else {
        let m = n as f64;
        m * m.ln() - m + 0.5 * (std::f64::consts::TAU * m).ln() + 1.0 / (12.0 * m)
            - 1.0 / (360.0 * m * m * m)
    };
    (n as f64 * lambda.ln() - lambda - ln_fact).exp()
}

/// Standard normal CDF (Abramowitz & Stegun 7.1.26 for erf, |error| < 1.5e-7).
fn normal_cdf(z: f64) -> f64 {
    let x = z.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * x);
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let erf = 1.0 - poly * (-x * x).exp();
    if z >= 0.0 {
        0.5 * (1.0 + erf)
    } else {
        0.5 * (1.0 - erf)
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
    /// Under a modelled light level: the photon model's quantiles.
    photon: Option<PhotonTable>,
    /// Quantile indices, `POOL_FRAMES` frames' worth.
    uniform_pool: Vec<u16>,
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
        if let Some(photon) = &self.photon {
            let len = out.len();
            if self.uniform_pool.len() != POOL_FRAMES * len {
                let rng = &mut self.rng;
                self.uniform_pool = (0..POOL_FRAMES * len)
                    .map(|_| rng.gen_range(0..QUANTILES as u16))
                    .collect();
            }
            let start = self.rng.gen_range(0..=(POOL_FRAMES - 1) * len);
            for (v, &j) in out.iter_mut().zip(&self.uniform_pool[start..start + len]) {
                *v = photon.quantiles[usize::from(*v)][usize::from(j)];
            }
        }
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

    /// Mean and (sample) variance of a frame's values.
    fn mean_and_variance(values: &[u8]) -> (f64, f64) {
        let n = values.len() as f64;
        let mean = values.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
        let var = values
            .iter()
            .map(|&v| (f64::from(v) - mean).powi(2))
            .sum::<f64>()
            / (n - 1.0);
        (mean, var)
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
        let (mean, var) = mean_and_variance(&out);
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
    fn the_photon_model_has_the_mean_and_variance_of_its_electrons() {
        for lux in [500.0, 20.0, 5.0] {
            let camera = crate::light::RGB_CAMERA;
            let e = camera.exposure(lux);
            let noise = RgbNoise {
                lux,
                ..RgbNoise::default()
            };
            let flat = vec![128u8; 200_000];
            let out = noise.sensor(&mut rng(3)).apply(&[&flat]);
            let (mean, var) = mean_and_variance(&out);
            let electrons = e.white_e * 128.0 / 255.0;
            let k = e.gain_grey_per_e;
            let want_mean = k * electrons;
            // Poisson + read noise, then rounding (1/12 grey²).
            let want_var = k * k * (electrons + camera.read_noise_e.powi(2)) + 1.0 / 12.0;
            assert!(
                (mean - want_mean).abs() < 0.05 + 0.01 * want_mean,
                "{lux}: {mean}"
            );
            assert!(
                (var / want_var - 1.0).abs() < 0.1,
                "{lux}: {var} vs {want_var}"
            );
        }
    }

    #[test]
    fn poisson_and_normal_helpers_are_right() {
        let total: f64 = (0..200).map(|n| poisson_pmf(30.0, n)).sum();
        assert!((total - 1.0).abs() < 1e-9, "{total}");
        assert!((poisson_pmf(2.0, 3) - 8.0 / 6.0 * (-2f64).exp()).abs() < 1e-12);
        let big: f64 = (0..20_000).map(|n| poisson_pmf(8000.0, n)).sum();
        assert!((big - 1.0).abs() < 1e-6, "{big}");
        assert!((normal_cdf(0.0) - 0.5).abs() < 1e-7);
        assert!((normal_cdf(1.959_964) - 0.975).abs() < 1e-6);
        assert!((normal_cdf(-1.0) - 0.158_655_25).abs() < 1e-6);
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
