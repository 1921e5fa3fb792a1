//! Space-time reservations: what the concurrent safety router checks before letting a trip
//! overlap others.
//!
//! A trip's reservation is its whole future trajectory fixed at departure: the outbound leg,
//! the hover at the site for the service time, the return leg (the outbound path reversed),
//! then rest at home for ever. In concurrent mode the scheduler flies exactly that (a trip
//! that finds no work still hovers out its reserved service time), so a reservation checked
//! once stays true.
//!
//! **The check is sampled, with a bound for what happens between samples.** Legs are
//! minimum-jerk blends whose peak speed is at most `speed_mps` (see
//! [`crate::trajectory::segment_duration_ns`]), and a hover does not move, so two drones
//! close in on each other at no more than `2·speed_mps`. Any instant lies within
//! [`SAMPLE_NS`]/2 of a sample, so if every sample keeps `clearance + speed_mps·SAMPLE_NS`
//! between body centres (in space), every instant keeps `clearance`.

use crate::config::FlightLimits;
use crate::trajectory::Leg;

/// Sample spacing of the space-time check (20 ms: half a tick).
pub const SAMPLE_NS: u64 = 20_000_000;

#[derive(Debug, Clone, PartialEq)]
enum Piece {
    Fly(Leg),
    Hover { until_ns: u64, at_m: [f64; 3] },
}

/// One drone's committed trajectory from its start on, then rest at `home_m`.
#[derive(Debug, Clone, PartialEq)]
pub struct Reservation {
    start_ns: u64,
    home_m: [f64; 3],
    pieces: Vec<Piece>,
}

impl Reservation {
    /// A trip: `outbound` (home → site), hover at the site until `hover_until_ns`, then
    /// `inbound` (site → home).
    pub fn trip(outbound: Leg, hover_until_ns: u64, inbound: Leg) -> Self {
        let at_m = outbound.waypoints().last().copied().unwrap_or([0.0; 3]);
        let home_m = inbound.waypoints().last().copied().unwrap_or(at_m);
        Self {
            start_ns: outbound.start_ns(),
            home_m,
            pieces: vec![
                Piece::Fly(outbound),
                Piece::Hover {
                    until_ns: hover_until_ns,
                    at_m,
                },
                Piece::Fly(inbound),
            ],
        }
    }

    /// When the drone is home for good.
    pub fn end_ns(&self) -> u64 {
        self.pieces.iter().fold(self.start_ns, |t, p| match p {
            Piece::Fly(leg) => t.max(leg.end_ns()),
            Piece::Hover { until_ns, .. } => t.max(*until_ns),
        })
    }

    /// Commanded position at `t_ns` (at the first piece's start before it, home after the end).
    pub fn position_at(&self, t_ns: u64) -> [f64; 3] {
        for p in &self.pieces {
            match p {
                Piece::Fly(leg) if t_ns <= leg.end_ns() => return leg.state_at(t_ns).pos_m,
                Piece::Hover { until_ns, at_m } if t_ns <= *until_ns => return *at_m,
                _ => {}
            }
        }
        self.home_m
    }
}

/// Whether `a` and `b` keep `clearance_m` between body centres at every instant from `from_ns`
/// until both are home for good (and beyond, when their homes are that far apart), for drones
/// no faster than `speed_mps`.
pub fn keep_clear(
    a: &Reservation,
    b: &Reservation,
    from_ns: u64,
    clearance_m: f64,
    speed_mps: f64,
) -> bool {
    let need_m = clearance_m + speed_mps * SAMPLE_NS as f64 * 1e-9;
    let end_ns = a.end_ns().max(b.end_ns());
    let mut t = from_ns;
    loop {
        if proto::scene::distance_m(a.position_at(t), b.position_at(t)) < need_m {
            return false;
        }
        if t >= end_ns {
            return true;
        }
        t = t.saturating_add(SAMPLE_NS).min(end_ns);
    }
}

/// The concurrent router's rule: `candidate`, leaving at `now_ns`, keeps the clearance from
/// every reservation in `flying` for as long as either lasts.
pub fn admit(
    flying: &[&Reservation],
    candidate: &Reservation,
    now_ns: u64,
    limits: &FlightLimits,
) -> bool {
    flying
        .iter()
        .all(|r| keep_clear(r, candidate, now_ns, limits.clearance_m, limits.speed_mps))
}
