//! Simulated time: integer nanoseconds, the 2 ms physics step and the 40 ms tick.

use serde::{Deserialize, Serialize};

use crate::codec::Validate;

/// Physics step, nanoseconds (500 Hz).
pub const PHYSICS_STEP_NS: u64 = 2_000_000;
/// One tick: the 40 ms sensor-packet period.
pub const TICK_NS: u64 = 40_000_000;
/// Physics steps per tick.
pub const STEPS_PER_TICK: u64 = TICK_NS / PHYSICS_STEP_NS;
/// Render period of the event source (100 Hz).
pub const EVENT_RENDER_PERIOD_NS: u64 = 10_000_000;
/// Render period of the RGB camera (25 Hz).
pub const RGB_RENDER_PERIOD_NS: u64 = 40_000_000;

/// Sim time `t_k` at the end of tick `k`, or `None` if it does not fit in a `u64`.
pub fn tick_end_ns(tick: u64) -> Option<u64> {
    tick.checked_mul(TICK_NS)
}

/// True when `stamp_ns` lies in tick `k`'s interval `(t_{k−1}, t_k]` (tick 0 is `[0, 0]`).
pub fn stamp_in_tick(stamp_ns: u64, tick: u64) -> bool {
    match tick_end_ns(tick) {
        Some(end) => stamp_ns <= end && (tick == 0 || stamp_ns > end - TICK_NS),
        None => false,
    }
}

/// Published by the simulator once physics has reached `t_k = k · 40 ms`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ClockTick {
    pub tick: u64,
    pub sim_time_ns: u64,
}

impl ClockTick {
    /// The tick `k` with its sim time; `None` past the representable range.
    pub fn at(tick: u64) -> Option<Self> {
        tick_end_ns(tick).map(|sim_time_ns| Self { tick, sim_time_ns })
    }
}

impl Validate for ClockTick {
    fn validate(&self) -> Result<(), String> {
        if tick_end_ns(self.tick) != Some(self.sim_time_ns) {
            return Err(format!(
                "clock tick {} carries sim time {} ns, want tick · {TICK_NS}",
                self.tick, self.sim_time_ns
            ));
        }
        Ok(())
    }
}

/// Checks that every value is finite; `what` names the field in the error.
pub(crate) fn check_finite(what: &str, values: &[f64]) -> Result<(), String> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(format!("{what} has a non-finite value: {values:?}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_40_ms_of_20_steps() {
        assert_eq!(STEPS_PER_TICK, 20);
        assert_eq!(
            ClockTick::at(3),
            Some(ClockTick {
                tick: 3,
                sim_time_ns: 120_000_000
            })
        );
        assert!(ClockTick::at(3).unwrap().validate().is_ok());
        assert!(
            ClockTick {
                tick: 3,
                sim_time_ns: 1
            }
            .validate()
            .is_err()
        );
        assert!(
            ClockTick {
                tick: u64::MAX,
                sim_time_ns: 0
            }
            .validate()
            .is_err()
        );
        assert_eq!(ClockTick::at(u64::MAX), None);
    }

    #[test]
    fn tick_intervals_are_left_open() {
        assert!(stamp_in_tick(0, 0));
        assert!(!stamp_in_tick(1, 0));
        assert!(!stamp_in_tick(40_000_000, 2));
        assert!(stamp_in_tick(40_000_001, 2));
        assert!(stamp_in_tick(80_000_000, 2));
        assert!(!stamp_in_tick(0, u64::MAX));
    }
}
