//! Time-parameterised flight legs: each straight segment of a path is one minimum-jerk blend
//! from rest to rest, so position, velocity and acceleration are continuous along the whole leg
//! (and zero at every waypoint): the simulator's controller tracks it with its feed-forward
//! terms within millimetres.

use proto::min_jerk;
use proto::{Kinematics, TICK_NS};

use crate::config::FlightLimits;
use crate::error::NavError;

#[derive(Debug, Clone, Copy, PartialEq)]
struct Segment {
    start_ns: u64,
    end_ns: u64,
    from_m: [f64; 3],
    to_m: [f64; 3],
}

/// One leg (home → site or site → home) along a polyline, starting at rest at `start_ns`.
#[derive(Debug, Clone, PartialEq)]
pub struct Leg {
    start_ns: u64,
    waypoints: Vec<[f64; 3]>,
    segments: Vec<Segment>,
}

/// Duration of one rest-to-rest blend over `length_m`, whole ticks.
pub fn segment_duration_ns(length_m: f64, limits: &FlightLimits) -> Result<u64, NavError> {
    let t_acc_s = (min_jerk::PEAK_ACCELERATION_FACTOR * length_m / limits.accel_mps2).sqrt();
    let t_vel_s = min_jerk::PEAK_VELOCITY_FACTOR * length_m / limits.speed_mps;
    let t_s = t_acc_s.max(t_vel_s);
    if !t_s.is_finite() {
        return Err(NavError::TimeOverflow);
    }
    let ticks = (t_s * 1e9 / TICK_NS as f64).ceil();
    if ticks >= (u64::MAX / TICK_NS) as f64 {
        return Err(NavError::TimeOverflow);
    }
    Ok((ticks as u64 * TICK_NS).max(limits.min_segment_ns.div_ceil(TICK_NS) * TICK_NS))
}

impl Leg {
    /// Plans the leg through `waypoints` (first = where the drone rests at `start_ns`).
    /// Zero-length segments are skipped.
    pub fn plan(
        start_ns: u64,
        waypoints: &[[f64; 3]],
        limits: &FlightLimits,
    ) -> Result<Self, NavError> {
        let mut segments = Vec::new();
        let mut t = start_ns;
        for w in waypoints.windows(2) {
            let length_m = planar_distance_m(w[0], w[1]).hypot(w[1][2] - w[0][2]);
            if length_m <= 0.0 {
                continue;
            }
            let end_ns = t
                .checked_add(segment_duration_ns(length_m, limits)?)
                .ok_or(NavError::TimeOverflow)?;
            segments.push(Segment {
                start_ns: t,
                end_ns,
                from_m: w[0],
                to_m: w[1],
            });
            t = end_ns;
        }
        Ok(Self {
            start_ns,
            waypoints: waypoints.to_vec(),
            segments,
        })
    }

    /// The same path flown backwards, starting at `start_ns`.
    pub fn reversed(&self, start_ns: u64, limits: &FlightLimits) -> Result<Self, NavError> {
        let mut w = self.waypoints.clone();
        w.reverse();
        Self::plan(start_ns, &w, limits)
    }

    pub fn start_ns(&self) -> u64 {
        self.start_ns
    }

    /// Arrival time (the drone is at rest at the last waypoint from then on).
    pub fn end_ns(&self) -> u64 {
        self.segments.last().map_or(self.start_ns, |s| s.end_ns)
    }

    pub fn waypoints(&self) -> &[[f64; 3]] {
        &self.waypoints
    }

    /// Commanded state at `t_ns` (at rest at the ends outside the leg's interval).
    pub fn state_at(&self, t_ns: u64) -> Kinematics {
        let first = self.waypoints.first().copied().unwrap_or([0.0; 3]);
        let last = self.waypoints.last().copied().unwrap_or(first);
        if t_ns <= self.start_ns || self.segments.is_empty() {
            return Kinematics::rest(first);
        }
        if t_ns >= self.end_ns() {
            return Kinematics::rest(last);
        }
        let i = self.segments.partition_point(|s| s.end_ns <= t_ns);
        let s = &self.segments[i];
        let span_ns = s.end_ns - s.start_ns;
        let u = (t_ns - s.start_ns) as f64 / span_ns as f64;
        let dt_s = span_ns as f64 * 1e-9;
        let (p, v, a) = (
            min_jerk::position(u),
            min_jerk::velocity(u),
            min_jerk::acceleration(u),
        );
        let d: [f64; 3] = std::array::from_fn(|k| s.to_m[k] - s.from_m[k]);
        Kinematics {
            pos_m: std::array::from_fn(|k| s.from_m[k] + d[k] * p),
            vel_mps: std::array::from_fn(|k| d[k] * v / dt_s),
            acc_mps2: std::array::from_fn(|k| d[k] * a / (dt_s * dt_s)),
        }
    }
}

/// Horizontal distance between two points.
pub fn planar_distance_m(a: [f64; 3], b: [f64; 3]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn norm(v: [f64; 3]) -> f64 {
        v.iter().map(|x| x * x).sum::<f64>().sqrt()
    }

    #[test]
    fn legs_respect_the_limits_and_are_continuous() {
        let l = FlightLimits::default();
        let w = [
            [0.0, 0.0, 1.3],
            [1.0, 0.0, 1.3],
            [1.0, 2.0, 1.3],
            [1.05, 2.0, 1.3],
        ];
        let leg = Leg::plan(400_000_000, &w, &l).unwrap();
        assert_eq!(leg.segments.len(), 3);
        for s in &leg.segments {
            assert_eq!((s.end_ns - s.start_ns) % TICK_NS, 0, "whole ticks");
            assert!(s.end_ns - s.start_ns >= l.min_segment_ns);
        }
        let mut prev = leg.state_at(leg.start_ns());
        assert_eq!(prev, Kinematics::rest(w[0]));
        let step = 1_000_000;
        let (mut vmax, mut amax) = (0.0f64, 0.0f64);
        let mut t = leg.start_ns();
        while t < leg.end_ns() + 2 * step {
            t += step;
            let k = leg.state_at(t);
            vmax = vmax.max(norm(k.vel_mps));
            amax = amax.max(norm(k.acc_mps2));
            // Continuity: no jumps between 1 ms samples.
            let dp = norm(std::array::from_fn(|i| k.pos_m[i] - prev.pos_m[i]));
            let dv = norm(std::array::from_fn(|i| k.vel_mps[i] - prev.vel_mps[i]));
            assert!(dp < 2e-3 && dv < 2e-3, "jump at {t}: {dp} m, {dv} m/s");
            prev = k;
        }
        assert!(
            vmax <= l.speed_mps + 1e-9 && vmax > 0.5,
            "peak speed {vmax}"
        );
        assert!(
            amax <= l.accel_mps2 + 1e-9 && amax > 0.3,
            "peak accel {amax}"
        );
        assert_eq!(leg.state_at(leg.end_ns()), Kinematics::rest(w[3]));
        // Waypoints are reached at rest.
        for s in &leg.segments {
            let k = leg.state_at(s.end_ns);
            assert!(norm(k.vel_mps) < 1e-12 && norm(k.acc_mps2) < 1e-12);
            assert!(norm(std::array::from_fn(|i| k.pos_m[i] - s.to_m[i])) < 1e-12);
        }
        let back = leg.reversed(leg.end_ns(), &l).unwrap();
        assert_eq!(
            back.end_ns() - back.start_ns(),
            leg.end_ns() - leg.start_ns()
        );
        assert_eq!(back.state_at(back.end_ns()).pos_m, w[0]);
    }

    #[test]
    fn duration_grows_with_length_and_never_falls_below_the_minimum() {
        let l = FlightLimits::default();
        assert_eq!(segment_duration_ns(0.01, &l).unwrap(), l.min_segment_ns);
        let a = segment_duration_ns(1.0, &l).unwrap();
        let b = segment_duration_ns(2.0, &l).unwrap();
        assert!(a < b);
        // 1 m at 0.5 m/s²: √(5.77·1/0.5) = 3.40 s → 3.40 s in whole ticks.
        assert_eq!(a, 3_400_000_000);
        assert!(segment_duration_ns(f64::NAN, &l).is_err());
    }
}
