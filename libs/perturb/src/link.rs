//! The sensor link's perturbations: independent packet loss and a constant delay.
//!
//! Each sensor message (an RGB frame or an event packet) is lost with probability `drop_rate`,
//! independently; a kept message arrives `delay_ms` late. A receiver orders its input by stamp,
//! so a constant delay does not change what it decodes, only when: the trial harness adds it to
//! every release instant (a FIFO link with constant delay does exactly that).

use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// The sensor stream's loss and delay; the default is a perfect link.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LinkNoise {
    /// Probability that a sensor message is lost, 0–1.
    pub drop_rate: f64,
    /// Constant delay of every sensor message, ms.
    pub delay_ms: f64,
}

impl LinkNoise {
    /// True when every message arrives at once.
    pub fn is_ideal(&self) -> bool {
        *self == Self::default()
    }

    /// Whether the next message arrives (draws from `rng` only when loss is configured, so a
    /// lossless link consumes no randomness).
    pub fn keeps(&self, rng: &mut ChaCha8Rng) -> bool {
        self.drop_rate <= 0.0 || rng.r#gen::<f64>() >= self.drop_rate
    }

    /// The delay, ns.
    pub fn delay_ns(&self) -> u64 {
        (self.delay_ms * 1e6).round() as u64
    }
}

#[cfg(test)]
mod tests {
    use rand::SeedableRng;

    use super::*;

    #[test]
    fn loss_rate_matches() {
        let link = LinkNoise {
            drop_rate: 0.2,
            delay_ms: 0.0,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let n = 100_000;
        let kept = (0..n).filter(|_| link.keeps(&mut rng)).count() as f64;
        // Binomial σ of the loss fraction ≈ 0.0013; 5σ.
        assert!((1.0 - kept / n as f64 - 0.2).abs() < 0.0065, "kept {kept}");
    }

    #[test]
    fn perfect_link_keeps_everything() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        assert!((0..1000).all(|_| LinkNoise::default().keeps(&mut rng)));
        assert_eq!(
            LinkNoise {
                drop_rate: 0.0,
                delay_ms: 12.5
            }
            .delay_ns(),
            12_500_000
        );
    }
}
