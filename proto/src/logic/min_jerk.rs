//! Minimum-jerk (quintic) blends between two rest points.
//!
//! `σ(s) = 10 s³ − 15 s⁴ + 6 s⁵` has zero velocity *and* zero acceleration at both ends, so
//! chaining blends through keypoints gives a setpoint whose velocity and acceleration are
//! continuous everywhere: the flight controller never sees a step in commanded acceleration.

/// Peak of `σ'(s)` (at s = ½): a blend over distance `d` in time `T` peaks at `1.875 d / T`.
pub const PEAK_VELOCITY_FACTOR: f64 = 1.875;
/// Peak of `|σ''(s)|` (at s = ½ ∓ √3/6): a blend peaks at `5.7735 d / T²`.
pub const PEAK_ACCELERATION_FACTOR: f64 = 5.773_502_691_896_258;

/// Position fraction `σ(s)` for `s ∈ [0, 1]` (clamped outside).
pub fn position(s: f64) -> f64 {
    let s = s.clamp(0.0, 1.0);
    s * s * s * (10.0 + s * (-15.0 + 6.0 * s))
}

/// `dσ/ds`.
pub fn velocity(s: f64) -> f64 {
    if !(0.0..=1.0).contains(&s) {
        return 0.0;
    }
    30.0 * s * s * (1.0 - s) * (1.0 - s)
}

/// `d²σ/ds²`.
pub fn acceleration(s: f64) -> f64 {
    if !(0.0..=1.0).contains(&s) {
        return 0.0;
    }
    60.0 * s * (1.0 - s) * (1.0 - 2.0 * s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blend_is_exact_at_the_ends_and_symmetric() {
        assert_eq!(position(0.0), 0.0);
        assert_eq!(position(1.0), 1.0);
        assert_eq!(velocity(0.0), 0.0);
        assert_eq!(velocity(1.0), 0.0);
        assert_eq!(acceleration(0.0), 0.0);
        assert_eq!(acceleration(1.0), 0.0);
        for k in 0..=100 {
            let s = k as f64 / 100.0;
            assert!((position(s) + position(1.0 - s) - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn derivatives_match_finite_differences_and_peak_factors() {
        let h = 1e-6;
        let mut v_max = 0.0f64;
        let mut a_max = 0.0f64;
        for k in 1..1000 {
            let s = k as f64 / 1000.0;
            let dv = (position(s + h) - position(s - h)) / (2.0 * h);
            let da = (velocity(s + h) - velocity(s - h)) / (2.0 * h);
            assert!((dv - velocity(s)).abs() < 1e-6, "s={s}");
            assert!((da - acceleration(s)).abs() < 1e-5, "s={s}");
            v_max = v_max.max(velocity(s));
            a_max = a_max.max(acceleration(s).abs());
        }
        assert!((v_max - PEAK_VELOCITY_FACTOR).abs() < 1e-9);
        assert!((a_max - PEAK_ACCELERATION_FACTOR).abs() < 1e-3);
    }
}
