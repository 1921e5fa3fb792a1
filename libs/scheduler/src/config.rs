//! Case options and every timing and flight constant of the scheduler, with the reasons for the
//! defaults.

use std::collections::BTreeMap;

use proto::Site;
use proto::scene::MAX_OBSERVERS;
use proto::sched::{MAX_BROADCAST_OFFERS, MAX_ROUND_BROADCASTS};
use proto::{GestureConfig, NS_PER_S};

use crate::error::ConfigError;

// The observers' sensing modality: only the broadcast differs (the events modality flies the
// acquisition sweep and its quiet before the first offer of every round).
use proto::FlightMode;
use proto::Modality;

/// Round and session timing.
///
/// | constant | default | why |
/// | --- | --- | --- |
/// | `broadcast_lead_ns` | 5 s | round start (reset, window open) → broadcast start; round 1 therefore broadcasts at 5.0 s (paper RGB: 5.002 s) and receivers see a still performer first |
/// | `window_margin_ns` | 1 s | broadcast end → window close; a receiver confirms the final NULL ≈ 3 s into its 5 s hold, so a late one still has ≈ 3 s |
/// | `decision_grace_ns` | 20 s | window close → decision deadline (only-A: paper 122.92 s ≈ 22 s after the final NULL) |
/// | `idle_end_ns` | 15 s | a round that broadcasts nothing ends the mission 15 s after it started (paper no-broadcast: 15.04 s) |
/// | `service_ns` | 5 s | the paper's virtual service |
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Timing {
    pub broadcast_lead_ns: u64,
    pub window_margin_ns: u64,
    pub decision_grace_ns: u64,
    pub idle_end_ns: u64,
    pub service_ns: u64,
}

impl Default for Timing {
    fn default() -> Self {
        Self {
            broadcast_lead_ns: 5 * NS_PER_S,
            window_margin_ns: NS_PER_S,
            decision_grace_ns: 20 * NS_PER_S,
            idle_end_ns: 15 * NS_PER_S,
            service_ns: 5 * NS_PER_S,
        }
    }
}

/// Flight and navigation limits.
///
/// Each straight segment of a path is one minimum-jerk blend from rest to rest, lasting
/// `max(min_segment, √(5.77·L / accel), 1.875·L / speed)` rounded up to whole 40 ms ticks, so
/// its peak acceleration is ≤ `accel_mps2` and its peak speed ≤ `speed_mps`. With 0.5 m/s² and
/// 1 m/s a nominal trip (home → site → 5 s service → home) takes 12–21 s: the paper's three
/// round-2 trips took 45.80 s (≈ 15.3 s each), ours take 46.92 s (O1 → B 21.08 s with one
/// detour waypoint around O2, O2 → B 13.88 s, O3 → B 11.96 s).
///
/// Clearances are between body centres in the horizontal plane (everything flies at the 1.3 m
/// nominal altitude); the Crazyflie collision spheres have a 0.07 m radius. The planner keeps
/// 0.4 m so that 0.35 m holds with centimetres of tracking error to spare.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlightLimits {
    pub accel_mps2: f64,
    pub speed_mps: f64,
    pub min_segment_ns: u64,
    /// Least distance from a path to another observer or to a site.
    pub clearance_m: f64,
    /// Least distance from a path to the performer's hover point (it gestures ≈ ±0.175 m).
    pub performer_clearance_m: f64,
    /// Detour waypoints sit this far outside an obstacle's clearance circle.
    pub ring_margin_m: f64,
    /// Detour waypoint candidates per obstacle.
    pub ring_points: usize,
}

impl Default for FlightLimits {
    fn default() -> Self {
        Self {
            accel_mps2: 0.5,
            speed_mps: 1.0,
            min_segment_ns: NS_PER_S,
            clearance_m: 0.4,
            performer_clearance_m: 0.5,
            ring_margin_m: 0.1,
            ring_points: 24,
        }
    }
}

/// One case as the scheduler sees it.
#[derive(Debug, Clone, PartialEq)]
pub struct SchedulerConfig {
    /// Observers `O1 … On` at the default scene's arc homes.
    pub observers: usize,
    pub modality: Modality,
    /// Sites advertised each round, in transmission order (offers from the task state). The
    /// paper sends A then B; `[A]` is the only-A case; empty = no broadcast at all.
    pub offer_sites: Vec<Site>,
    /// Number of rounds (the paper runs 2).
    pub rounds: u32,
    /// Initial work units of the sites it names, instead of the default `max(1, N − 1)` at A
    /// and `N + 1` at B (empty: the paper's task state).
    pub work: BTreeMap<Site, u32>,
    /// Broadcasts a round may fly: the round's offers again, whole, while a live observer has
    /// not decided when a broadcast's window would close (its decision says it holds every
    /// offer). 1 is the paper's one-shot broadcast.
    pub max_broadcasts: u32,
    /// Gesture timing, so the scheduler knows exactly when a broadcast ends.
    pub gesture: GestureConfig,
    pub timing: Timing,
    pub flight: FlightLimits,
    /// Hard stop: the mission ends at this sim time whatever is happening.
    pub time_limit_ns: Option<u64>,
    /// One trip at a time (the paper) or overlapping trips on checked reservations.
    pub flights: FlightMode,
    /// The check every frame carries after its payload (none: the paper's frame).
    pub frame_check: proto::FrameCheck,
}

impl SchedulerConfig {
    /// The paper's two-round mission for `observers` observers.
    pub fn new(observers: usize, modality: Modality) -> Self {
        Self {
            observers,
            modality,
            offer_sites: Site::ALL.to_vec(),
            rounds: 2,
            work: BTreeMap::new(),
            max_broadcasts: 1,
            gesture: GestureConfig::default(),
            timing: Timing::default(),
            flight: FlightLimits::default(),
            time_limit_ns: None,
            flights: FlightMode::default(),
            frame_check: proto::FrameCheck::None,
        }
    }

    /// The no-broadcast control.
    pub fn without_broadcast(mut self) -> Self {
        self.offer_sites.clear();
        self
    }

    /// Advertise only these sites (e.g. `[Site::A]` for the only-A case).
    pub fn with_offer_sites(mut self, sites: &[Site]) -> Self {
        self.offer_sites = sites.to_vec();
        self
    }

    pub fn validate(&self) -> Result<(), ConfigError> {
        if !(1..=MAX_OBSERVERS).contains(&self.observers) {
            return Err(ConfigError::ObserverCount {
                observers: self.observers,
            });
        }
        if self.rounds == 0 {
            return Err(ConfigError::NoRounds);
        }
        if !(1..=MAX_ROUND_BROADCASTS).contains(&self.max_broadcasts) {
            return Err(ConfigError::MaxBroadcasts {
                max_broadcasts: self.max_broadcasts,
            });
        }
        if self.offer_sites.len() > MAX_BROADCAST_OFFERS {
            return Err(ConfigError::TooManyOffers {
                offers: self.offer_sites.len(),
            });
        }
        let f = &self.flight;
        let positive = |v: f64| v.is_finite() && v > 0.0;
        if !positive(f.accel_mps2)
            || !positive(f.speed_mps)
            || !positive(f.clearance_m)
            || !positive(f.performer_clearance_m)
            || !f.ring_margin_m.is_finite()
            || f.ring_margin_m < 0.0
            || f.ring_points < 3
            || f.min_segment_ns == 0
        {
            return Err(ConfigError::FlightLimits);
        }
        if self.timing.service_ns == 0 {
            return Err(ConfigError::ZeroService);
        }
        Ok(())
    }
}
