//! A small seeded Gaussian source for the physics-side random processes (wind turbulence, state
//! estimate noise).
//!
//! Why not `rand`: this crate draws few numbers (a handful per 2 ms physics step) and must give
//! the same realisation for a seed on every machine and in every binary; SplitMix64 (Steele, Lea
//! & Flood, OOPSLA 2014) passes BigCrush, needs eight lines and keeps `sim` free of a new
//! dependency edge. Normal draws use the Box–Muller transform with std's `ln`, `sqrt` and
//! `sin_cos`. Seeds for these streams come from the trial seed (`perturb::seed`).

/// SplitMix64's output function: a bijective 64-bit mix (the same as `perturb::seed::mix`).
pub fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A seeded stream of standard normal draws.
#[derive(Debug, Clone)]
pub struct Gaussian {
    state: u64,
    spare: Option<f64>,
}

impl Gaussian {
    /// The stream of `seed`; `sub` separates streams drawn from one seed (per drone, per axis).
    pub fn new(seed: u64, sub: u64) -> Self {
        Self {
            state: mix(seed ^ mix(sub)),
            spare: None,
        }
    }

    fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform on (0, 1]: 53 random bits, never zero (so `ln` is finite).
    fn uniform_open0(&mut self) -> f64 {
        ((self.next_u64() >> 11) + 1) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// One standard normal draw.
    pub fn normal(&mut self) -> f64 {
        if let Some(z) = self.spare.take() {
            return z;
        }
        let r = (-2.0 * self.uniform_open0().ln()).sqrt();
        let (s, c) = (std::f64::consts::TAU * self.uniform_open0()).sin_cos();
        self.spare = Some(r * s);
        r * c
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_are_standard_normal_and_reproducible() {
        let mut g = Gaussian::new(42, 0);
        let n = 200_000;
        let xs: Vec<f64> = (0..n).map(|_| g.normal()).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(mean.abs() < 0.01, "mean {mean}");
        assert!((var - 1.0).abs() < 0.01, "variance {var}");
        let mut again = Gaussian::new(42, 0);
        assert!(xs.iter().take(100).all(|&x| x == again.normal()));
        assert_ne!(Gaussian::new(42, 1).normal(), xs[0]);
    }
}
