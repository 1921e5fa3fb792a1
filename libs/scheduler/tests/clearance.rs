//! Every planned trip of every observer to every site, N = 1..=8, keeps the planning clearance
//! (0.4 m, so ≥ 0.35 m with tracking error to spare) between body centres from every stationary
//! drone (0.5 m from the performer), sampled every 5 ms along the time-parameterised setpoints,
//! out and back.

use proto::Site;
use proto::scene::{MAX_OBSERVERS, PERFORMER_HOVER_M, distance_m, observer_home_m};
use scheduler::navigation::{obstacles, plan_path, segment_distance_m};
use scheduler::{FlightLimits, Leg};

#[test]
fn every_trip_keeps_its_clearance_for_one_to_eight_observers() {
    let limits = FlightLimits::default();
    assert!(limits.clearance_m >= 0.35);
    let need = limits.clearance_m - 1e-9;
    let mut worst = f64::INFINITY;
    let mut worst_performer = f64::INFINITY;
    let mut longest_trip_s = 0.0f64;
    let mut straight_violations = 0;
    for n in 1..=MAX_OBSERVERS {
        for i in 0..n {
            for site in Site::ALL {
                let others: Vec<[f64; 3]> = (0..n)
                    .filter(|&j| j != i)
                    .map(|j| observer_home_m(j, n))
                    .collect();
                let other_site = Site::ALL.into_iter().find(|&s| s != site).unwrap();
                let obs = obstacles(
                    others.iter().map(|h| ("other".to_owned(), *h)),
                    [("site".to_owned(), other_site.position_m())],
                    &limits,
                );
                let home = observer_home_m(i, n);
                if others
                    .iter()
                    .any(|h| segment_distance_m(*h, home, site.position_m()) < 0.35)
                {
                    straight_violations += 1;
                }
                let path = plan_path(home, site.position_m(), &obs, &limits)
                    .unwrap_or_else(|e| panic!("N={n} O{} → {site}: {e}", i + 1));
                let out = Leg::plan(0, &path, &limits).unwrap();
                let back = out.reversed(out.end_ns(), &limits).unwrap();
                longest_trip_s = longest_trip_s.max(back.end_ns() as f64 * 1e-9 + 5.0);
                let mut t = 0;
                while t <= back.end_ns() {
                    let p = if t <= out.end_ns() {
                        out.state_at(t).pos_m
                    } else {
                        back.state_at(t).pos_m
                    };
                    // Altitude stays between home's (either row) and the site's.
                    let (lo, hi) = (home[2].min(1.3), home[2].max(1.3));
                    assert!(p[2] >= lo - 1e-12 && p[2] <= hi + 1e-12, "altitude {p:?}");
                    for h in &others {
                        let d = distance_m(p, *h);
                        worst = worst.min(d);
                        assert!(d >= need, "N={n} O{} → {site}: {d:.3} m from {h:?}", i + 1);
                    }
                    let d = distance_m(p, other_site.position_m());
                    assert!(d >= need, "N={n} O{} passes site {other_site}", i + 1);
                    let dp = distance_m(p, PERFORMER_HOVER_M);
                    worst_performer = worst_performer.min(dp);
                    assert!(
                        dp >= limits.performer_clearance_m,
                        "N={n} O{} → {site}: {dp:.3} m from performer",
                        i + 1
                    );
                    t += 5_000_000;
                }
                assert_eq!(out.state_at(out.end_ns()).pos_m, site.position_m());
                assert_eq!(back.state_at(back.end_ns()).pos_m, home);
            }
        }
    }
    // The planner is needed: several straight lines would violate the clearance.
    assert!(straight_violations >= 5, "{straight_violations}");
    println!(
        "closest approach to an observer {worst:.3} m, to the performer {worst_performer:.3} m, \
         longest trip {longest_trip_s:.2} s, straight-line violations {straight_violations}"
    );
}

#[test]
fn nominal_paths() {
    // Printed for the report; the N = 3 detours are the ones the straight line would ruin.
    let limits = FlightLimits::default();
    for i in 0..3 {
        for site in Site::ALL {
            let obs = obstacles(
                (0..3)
                    .filter(|&j| j != i)
                    .map(|j| (format!("O{}", j + 1), observer_home_m(j, 3))),
                Site::ALL
                    .into_iter()
                    .filter(|&s| s != site)
                    .map(|s| (s.to_string(), s.position_m())),
                &limits,
            );
            let path = plan_path(observer_home_m(i, 3), site.position_m(), &obs, &limits).unwrap();
            let leg = Leg::plan(0, &path, &limits).unwrap();
            let pts: Vec<String> = path
                .iter()
                .map(|p| format!("({:.2},{:.2})", p[0], p[1]))
                .collect();
            println!(
                "O{} → {site}: {} leg {:.2} s",
                i + 1,
                pts.join(" "),
                leg.end_ns() as f64 * 1e-9
            );
        }
    }
}
