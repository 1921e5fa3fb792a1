//! Success rates with their uncertainty.

/// z for a two-sided 95 % interval (the 0.975 quantile of the standard normal).
pub const Z95: f64 = 1.959_963_984_540_054;

/// The Wilson score interval `[low, high]` for `successes` out of `trials` at `z` (Wilson 1927):
/// unlike the normal approximation it stays inside [0, 1] and is sensible at 0 or `trials`
/// successes. `[0, 1]` when there are no trials.
pub fn wilson(successes: u64, trials: u64, z: f64) -> [f64; 2] {
    if trials == 0 {
        return [0.0, 1.0];
    }
    let n = trials as f64;
    let p = successes.min(trials) as f64 / n;
    let z2 = z * z;
    let centre = (p + z2 / (2.0 * n)) / (1.0 + z2 / n);
    let half = z / (1.0 + z2 / n) * (p * (1.0 - p) / n + z2 / (4.0 * n * n)).sqrt();
    [(centre - half).max(0.0), (centre + half).min(1.0)]
}

/// The 95 % Wilson score interval.
pub fn wilson95(successes: u64, trials: u64) -> [f64; 2] {
    wilson(successes, trials, Z95)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f64; 2], b: [f64; 2]) {
        assert!(
            (a[0] - b[0]).abs() < 5e-5 && (a[1] - b[1]).abs() < 5e-5,
            "{a:?} vs {b:?}"
        );
    }

    #[test]
    fn known_values() {
        // Worked values (Newcombe 1998, table I, method 3 = Wilson without continuity
        // correction): 81/263 → 0.2553–0.3662; 15/148 → 0.0624–0.1605; 0/20 → 0–0.1611;
        // 1/29 → 0.0061–0.1718.
        close(wilson95(81, 263), [0.2553, 0.3662]);
        close(wilson95(15, 148), [0.0624, 0.1605]);
        close(wilson95(0, 20), [0.0, 0.1611]);
        close(wilson95(1, 29), [0.0061, 0.1718]);
        // All successes mirror none.
        close(wilson95(20, 20), [1.0 - 0.1611, 1.0]);
        close(wilson95(100, 100), [0.963, 1.0]);
    }

    #[test]
    fn degenerate_inputs() {
        assert_eq!(wilson95(0, 0), [0.0, 1.0]);
        let [lo, hi] = wilson95(5, 10);
        assert!(lo < 0.5 && hi > 0.5 && (0.5 - lo - (hi - 0.5)).abs() < 1e-12);
    }
}
