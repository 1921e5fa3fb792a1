//! The concurrent safety router: trips it lets overlap never come closer than the clearance,
//! and whole missions with overlapping flights keep the separation and finish sooner.

mod harness;

use harness::{Case, Run, run, secs};
use proptest::prelude::*;
use proto::FlightMode;
use proto::Modality;
use proto::Site;
use proto::scene::{MAX_OBSERVERS, distance_m, observer_home_m};
use proto::sched::SessionEvent;
use scheduler::navigation::{obstacles, plan_path};
use scheduler::reservation::{Reservation, admit};
use scheduler::{FlightLimits, Leg};

const SERVICE_NS: u64 = 5_000_000_000;

/// The trip observer `i` of `n` would fly to `site` leaving at `start_ns`, planned around the
/// observers on the ground (everyone but itself and `away`), as the router does.
fn trip(n: usize, i: usize, away: Option<usize>, site: Site, start_ns: u64) -> Reservation {
    let limits = FlightLimits::default();
    let others = (0..n)
        .filter(|&j| j != i && Some(j) != away)
        .map(|j| (format!("O{}", j + 1), observer_home_m(j, n)));
    let free = Site::ALL
        .into_iter()
        .filter(|&s| s != site)
        .map(|s| (format!("site {s}"), s.position_m()));
    let obs = obstacles(others, free, &limits);
    let path = plan_path(observer_home_m(i, n), site.position_m(), &obs, &limits).unwrap();
    let out = Leg::plan(start_ns, &path, &limits).unwrap();
    let hover_until_ns = out.end_ns() + SERVICE_NS;
    let back = out.reversed(hover_until_ns, &limits).unwrap();
    Reservation::trip(out, hover_until_ns, back)
}

/// Least distance between the two trips, every 2 ms from `from_ns` until both are home.
fn least_distance(a: &Reservation, b: &Reservation, from_ns: u64) -> f64 {
    let end = a.end_ns().max(b.end_ns());
    (from_ns..=end)
        .step_by(2_000_000)
        .map(|t| distance_m(a.position_at(t), b.position_at(t)))
        .fold(f64::INFINITY, f64::min)
}

/// Whether `b` (leaving at `t2`) overlaps `a` in time.
fn overlaps(a: &Reservation, t2: u64) -> bool {
    t2 < a.end_ns()
}

/// Observer `j` leaves `t2_s` after `i`: if the router admits it, the pair keeps the
/// clearance. Returns whether it was admitted while `i` was still out.
fn admitted_pair_keeps_clear(n: usize, i: usize, j: usize, sites: (Site, Site), t2_s: u64) -> bool {
    let limits = FlightLimits::default();
    let t2 = t2_s * 1_000_000_000;
    let a = trip(n, i, None, sites.0, 0);
    let b = trip(n, j, Some(i), sites.1, t2);
    if !admit(&[&a], &b, t2, &limits) {
        return false;
    }
    let d = least_distance(&a, &b, t2);
    assert!(
        d >= limits.clearance_m - 1e-9,
        "N={n}: O{} → {:?} and O{} → {:?} (+{t2_s} s) come {d:.3} m close",
        i + 1,
        sites.0,
        j + 1,
        sites.1
    );
    overlaps(&a, t2)
}

#[test]
fn every_admitted_pair_keeps_the_clearance_and_some_pairs_overlap() {
    let mut overlapping = 0;
    let mut refused = 0;
    for n in 2..=MAX_OBSERVERS {
        for i in 0..n {
            for j in (0..n).filter(|&j| j != i) {
                for sites in [
                    (Site::A, Site::A),
                    (Site::A, Site::B),
                    (Site::B, Site::A),
                    (Site::B, Site::B),
                ] {
                    for t2_s in [0, 3, 10, 20] {
                        if admitted_pair_keeps_clear(n, i, j, sites, t2_s) {
                            overlapping += 1;
                        } else if t2_s == 0 {
                            refused += 1;
                        }
                    }
                }
            }
        }
    }
    println!("{overlapping} overlapping pairs admitted, {refused} refused at once");
    assert!(
        overlapping > 100,
        "the router let only {overlapping} pairs overlap"
    );
    assert!(
        refused > 0,
        "the router never refused a pair: it cannot be checking"
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Random pairs of trips (group size, observers, sites, departure offset to the tick): the
    /// router never admits a pair that comes closer than the clearance.
    #[test]
    fn random_admitted_pairs_keep_the_clearance(
        n in 2..=MAX_OBSERVERS,
        i in 0..MAX_OBSERVERS,
        j in 0..MAX_OBSERVERS,
        a_to_b in any::<bool>(),
        b_to_b in any::<bool>(),
        t2_ticks in 0u64..1000,
    ) {
        let (i, j) = (i % n, j % n);
        prop_assume!(i != j);
        let site = |b: bool| if b { Site::B } else { Site::A };
        let limits = FlightLimits::default();
        let t2 = t2_ticks * 40_000_000;
        let a = trip(n, i, None, site(a_to_b), 0);
        let b = trip(n, j, Some(i), site(b_to_b), t2);
        if admit(&[&a], &b, t2, &limits) {
            let d = least_distance(&a, &b, t2);
            prop_assert!(d >= limits.clearance_m - 1e-9, "{d} m");
        }
    }
}

fn mission(n: usize, flights: FlightMode) -> Run {
    let mut case = Case::new(n, Modality::Events);
    case.config.flights = flights;
    run(&case)
}

/// Most observers away from home at once, and whether anyone was away during a window.
fn movers(run: &Run) -> (usize, bool) {
    let homes = run.sched.homes_m();
    let (mut most, mut during_window, mut open) = (0, false, false);
    for out in &run.outputs {
        for c in &out.session {
            match c.event {
                SessionEvent::WindowOpen { .. } => open = true,
                SessionEvent::WindowClose { .. } => open = false,
                _ => {}
            }
        }
        let away = out
            .setpoints
            .iter()
            .zip(homes)
            .filter(|(s, h)| s.kin.pos_m != **h)
            .count();
        most = most.max(away);
        during_window |= open && away > 0;
    }
    (most, during_window)
}

#[test]
fn concurrent_missions_overlap_flights_keep_separation_and_finish_sooner() {
    let limits = FlightLimits::default();
    for n in [3, 4, 6, 8] {
        let seq = mission(n, FlightMode::Sequential);
        let con = mission(n, FlightMode::Concurrent);
        let (most, during_window) = movers(&con);
        println!(
            "N={n}: sequential {:.2} s, concurrent {:.2} s; up to {most} in the air; least \
             separation {:.3} m (sequential {:.3} m)",
            secs(seq.end.1),
            secs(con.end.1),
            con.min_separation_m,
            seq.min_separation_m
        );
        assert!(most >= 2, "N={n}: flights never overlapped");
        assert!(
            !during_window,
            "N={n}: someone flew while a window was open"
        );
        assert!(con.min_separation_m >= limits.clearance_m - 1e-9, "N={n}");
        assert!(seq.min_separation_m >= limits.clearance_m - 1e-9, "N={n}");
        assert!(con.end.1 < seq.end.1, "N={n}: concurrent is not faster");
        assert_eq!(
            con.sched.stats().work_units + con.sched.stats().no_work_arrivals,
            con.sched.stats().departures,
            "N={n}: every departure ends in a service or a counted no-work"
        );
    }
}
