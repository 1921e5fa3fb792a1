//! Whole missions with ideal observers: the paper's functional cases at the scheduler level.

mod harness;

use std::collections::BTreeMap;

use harness::{Case, NS_PER_S, Run, run, secs};
use proto::EndReason;
use proto::Modality;
use proto::sched::SessionEvent;
use proto::{ObserverId, Site};
use scheduler::{DecisionNotice, DecisionReject, EventKind};

use Site::{A, B};

fn assignments(run: &Run, round: u32) -> Vec<Option<Site>> {
    run.decisions()
        .get(&round)
        .map(|m| m.values().copied().collect())
        .unwrap_or_default()
}

fn services(run: &Run, observer: &str) -> Vec<(u32, Site)> {
    run.sched
        .stats()
        .services
        .get(&ObserverId::new(observer).unwrap())
        .cloned()
        .unwrap_or_default()
}

/// Every tick: at most one observer away from home, nobody away while a window is open, and
/// everyone home at the end.
fn check_router_and_homes(run: &Run) {
    let homes = run.sched.homes_m();
    let mut window_open = false;
    for out in &run.outputs {
        for c in &out.session {
            match c.event {
                SessionEvent::WindowOpen { .. } => window_open = true,
                SessionEvent::WindowClose { .. } => window_open = false,
                _ => {}
            }
        }
        let away: Vec<_> = out
            .setpoints
            .iter()
            .zip(homes)
            .filter(|(s, h)| s.kin.pos_m != **h)
            .map(|(s, _)| s.observer.to_string())
            .collect();
        assert!(
            away.len() <= 1,
            "tick {}: several movers {away:?}",
            out.tick
        );
        assert!(
            !window_open || away.is_empty(),
            "tick {}: {away:?} moves while the window is open",
            out.tick
        );
    }
    let last = run.outputs.last().unwrap();
    for (s, h) in last.setpoints.iter().zip(homes) {
        assert_eq!(s.kin.pos_m, *h, "{} not home at the end", s.observer);
        assert_eq!(s.kin.vel_mps, [0.0; 3]);
    }
    let trips = run.trips();
    for w in trips.windows(2) {
        assert!(
            w[1].2 >= w[0].3,
            "trips overlap: {:?} then {:?}",
            w[0],
            w[1]
        );
    }
}

/// Provenance as the paper's audit sees it: final NULL ≤ decision ≤ departure.
fn check_provenance(run: &Run) {
    for (t, e) in run.events() {
        if let EventKind::Departure {
            decided_ns, round, ..
        } = e
        {
            let b = &run.sched.broadcasts()[*round as usize - 1];
            let last_null = b
                .scheduled
                .iter()
                .map(|s| s.final_null_start_ns + harness::NULL_CONFIRM_NS)
                .max()
                .unwrap();
            assert!(last_null <= *decided_ns && *decided_ns <= t, "{e:?} at {t}");
        }
    }
}

#[test]
fn nominal_three_observers_reproduce_the_papers_two_rounds() {
    for modality in [Modality::Rgb, Modality::Events] {
        let r = run(&Case::new(3, modality));
        assert_eq!(r.end.0, EndReason::RoundsComplete);
        assert_eq!(
            r.payloads(),
            vec![vec!["011010", "100111"], vec!["010000", "100111"]]
        );
        assert!(
            r.sched
                .broadcasts()
                .iter()
                .all(|b| b.acquisition == (modality == Modality::Events))
        );
        assert_eq!(assignments(&r, 1), vec![Some(A), Some(A), Some(B)]);
        assert_eq!(assignments(&r, 2), vec![Some(B), Some(B), Some(B)]);
        assert_eq!(r.sched.stats().work_units, 6);
        assert_eq!(services(&r, "O1"), vec![(1, A), (2, B)]);
        assert_eq!(services(&r, "O2"), vec![(1, A), (2, B)]);
        assert_eq!(services(&r, "O3"), vec![(1, B), (2, B)]);
        assert_eq!(r.sched.task().total_remaining(), 0);
        assert_eq!(r.frames, vec![4, 4, 4]);
        let order: Vec<String> = r.trips().into_iter().map(|t| t.0).collect();
        assert_eq!(order, ["O1", "O2", "O3", "O1", "O2", "O3"]);
        check_router_and_homes(&r);
        check_provenance(&r);
        assert_eq!(r.sched.stats().rejections(), 0);
        // Round 1 broadcasts at 5 s; the events broadcast is longer by the acquisition sweep.
        let b = &r.sched.broadcasts()[0];
        assert_eq!(b.start_ns, 5 * NS_PER_S);
        let first_offer = b.scheduled[0].start_ns;
        match modality {
            Modality::Rgb => assert_eq!(first_offer, 5 * NS_PER_S),
            Modality::Events => assert_eq!(first_offer, 9 * NS_PER_S),
        }
    }
}

#[test]
fn one_and_two_observers_do_two_and_four_units() {
    let r1 = run(&Case::new(1, Modality::Rgb));
    assert_eq!(r1.sched.stats().work_units, 2);
    assert_eq!(services(&r1, "O1"), vec![(1, A), (2, B)]);
    assert_eq!(
        r1.payloads(),
        vec![vec!["011001", "100110"], vec!["010000", "100110"]]
    );
    check_router_and_homes(&r1);
    let r2 = run(&Case::new(2, Modality::Rgb));
    assert_eq!(r2.sched.stats().work_units, 4);
    assert_eq!(services(&r2, "O1"), vec![(1, A), (2, B)]);
    assert_eq!(services(&r2, "O2"), vec![(1, B), (2, B)]);
    assert_eq!(r2.end.0, EndReason::RoundsComplete);
    check_router_and_homes(&r2);
    check_provenance(&r2);
}

#[test]
fn o2_black_does_four_units_and_o1_serves_a_twice() {
    let mut case = Case::new(3, Modality::Events);
    case.black.insert(1);
    let r = run(&case);
    assert_eq!(r.sched.stats().work_units, 4);
    assert_eq!(r.frames, vec![4, 0, 4]);
    assert_eq!(
        r.payloads(),
        vec![vec!["011010", "100111"], vec!["011001", "100111"]]
    );
    assert_eq!(services(&r, "O1"), vec![(1, A), (2, A)]);
    assert_eq!(services(&r, "O2"), vec![]);
    assert_eq!(services(&r, "O3"), vec![(1, B), (2, B)]);
    assert!(r.trips().iter().all(|t| t.0 != "O2"), "O2 never moves");
    assert_eq!(r.end.0, EndReason::RoundsComplete);
    // O2 is alive but silent: each window stays open until broadcast end + margin.
    for (t, e) in r.events() {
        if let EventKind::WindowClosed { round } = e {
            let b = &r.sched.broadcasts()[*round as usize - 1];
            assert_eq!(t, b.end_ns + NS_PER_S);
        }
    }
    check_router_and_homes(&r);
    check_provenance(&r);
}

/// Broadcasts per round, in order.
fn broadcasts_per_round(run: &Run) -> Vec<u32> {
    let mut per: BTreeMap<u32, u32> = BTreeMap::new();
    for b in run.sched.broadcasts() {
        *per.entry(b.round).or_default() += 1;
    }
    per.into_values().collect()
}

#[test]
fn a_repeated_broadcast_reaches_an_observer_that_missed_the_first() {
    // One-shot (the paper): O2 misses every round's only broadcast and never decides.
    let mut case = Case::new(3, Modality::Events);
    case.miss_first.insert(1);
    let once = run(&case);
    assert_eq!(broadcasts_per_round(&once), vec![1, 1]);
    assert_eq!(once.sched.stats().work_units, 4);
    // Up to three: the round flies its offers again once, O2 decides from the repeat, and the
    // mission does the paper's six units; the window closes as soon as O2 has decided.
    case.config.max_broadcasts = 3;
    let r = run(&case);
    assert_eq!(broadcasts_per_round(&r), vec![2, 2]);
    assert_eq!(r.sched.stats().work_units, 6);
    assert_eq!(services(&r, "O1"), vec![(1, A), (2, B)]);
    assert_eq!(services(&r, "O2"), vec![(1, A), (2, B)]);
    assert_eq!(services(&r, "O3"), vec![(1, B), (2, B)]);
    let broadcasts = r.sched.broadcasts();
    for (t, e) in r.events() {
        if let EventKind::WindowClosed { round } = e {
            let repeat = broadcasts.iter().rfind(|b| b.round == *round).unwrap();
            assert!(t < repeat.end_ns + NS_PER_S, "round {round} closed at {t}");
        }
    }
    // Each repeat starts a window margin after the broadcast before it ended, and flies the
    // same offers.
    for w in broadcasts.windows(2).filter(|w| w[0].round == w[1].round) {
        assert_eq!(w[1].start_ns, w[0].end_ns + NS_PER_S);
        assert_eq!(w[1].offers, w[0].offers);
    }
    check_router_and_homes(&r);
    check_provenance(&r);
}

#[test]
fn a_deaf_observer_holds_a_round_for_at_most_its_broadcasts() {
    let mut case = Case::new(3, Modality::Rgb);
    case.black.insert(1);
    case.config.max_broadcasts = 3;
    let r = run(&case);
    assert_eq!(broadcasts_per_round(&r), vec![3, 3]);
    assert_eq!(r.sched.stats().work_units, 4);
    for (t, e) in r.events() {
        if let EventKind::WindowClosed { round } = e {
            let last = r
                .sched
                .broadcasts()
                .iter()
                .rfind(|b| b.round == *round)
                .unwrap();
            assert_eq!(t, last.end_ns + NS_PER_S);
        }
    }
    for bad in [0, 9] {
        case.config.max_broadcasts = bad;
        let e = scheduler::Scheduler::new(case.config.clone())
            .unwrap_err()
            .to_string();
        assert!(e.contains(&format!("max_broadcasts = {bad}")), "{e}");
    }
}

#[test]
fn a_dead_observer_is_not_waited_for() {
    // O2's process dies at 35 s: same work outcome as black input, but the window closes as
    // soon as the live observers have decided.
    let mut case = Case::new(3, Modality::Events);
    case.dies_at_ns.insert(1, 35 * NS_PER_S);
    let r = run(&case);
    assert_eq!(r.sched.stats().work_units, 4);
    assert_eq!(services(&r, "O1"), vec![(1, A), (2, A)]);
    assert_eq!(services(&r, "O3"), vec![(1, B), (2, B)]);
    for (t, e) in r.events() {
        if let EventKind::WindowClosed { round } = e {
            let b = &r.sched.broadcasts()[*round as usize - 1];
            assert!(t < b.end_ns, "round {round} closed at {t}");
        }
    }
    check_router_and_homes(&r);
}

#[test]
fn no_broadcast_ends_after_15_s_with_nothing_done() {
    for modality in [Modality::Rgb, Modality::Events] {
        let mut case = Case::new(3, modality);
        case.config = case.config.without_broadcast();
        let r = run(&case);
        assert_eq!(r.end, (EndReason::NoBroadcast, 15 * NS_PER_S));
        assert!(r.sched.broadcasts().is_empty());
        assert!(r.outputs.iter().all(|o| o.broadcast.is_none()));
        assert_eq!(r.frames, vec![0, 0, 0]);
        assert_eq!(r.sched.stats().work_units, 0);
        assert_eq!(r.sched.stats().departures, 0);
        let last = r.outputs.last().unwrap();
        let events: Vec<_> = last.session.iter().map(|c| c.event).collect();
        assert_eq!(
            events,
            vec![
                SessionEvent::WindowClose { round: 1 },
                SessionEvent::MissionEnd
            ]
        );
    }
}

#[test]
fn only_a_sends_one_offer_and_ends_after_the_deadline_without_departures() {
    let mut case = Case::new(3, Modality::Rgb);
    case.config = case.config.with_offer_sites(&[A]);
    let r = run(&case);
    assert_eq!(r.payloads(), vec![vec!["011010"]]);
    assert_eq!(r.frames, vec![1, 1, 1]);
    assert!(r.decisions().is_empty());
    assert_eq!(r.sched.stats().departures, 0);
    assert_eq!(r.end.0, EndReason::NoDecision);
    let b = &r.sched.broadcasts()[0];
    assert_eq!(r.end.1, b.end_ns + NS_PER_S + 20 * NS_PER_S);
    assert!(
        r.events()
            .any(|(t, e)| matches!(e, EventKind::DeadlinePassed { round: 1 }) && t == r.end.1)
    );
    check_router_and_homes(&r);
}

#[test]
fn runs_are_deterministic() {
    let mut case = Case::new(3, Modality::Events);
    case.black.insert(1);
    let a = run(&case);
    let b = run(&case);
    assert_eq!(a.outputs, b.outputs);
    assert_eq!(a.sched.log(), b.sched.log());
    let n1 = run(&Case::new(3, Modality::Rgb));
    let n2 = run(&Case::new(3, Modality::Rgb));
    assert_eq!(n1.outputs, n2.outputs);
}

#[test]
fn bad_decisions_are_counted_and_change_nothing() {
    let id = |s: &str| ObserverId::new(s).unwrap();
    let notice = |o: &str, round: u32, site: Option<Site>, t_s: u64| DecisionNotice {
        observer: id(o),
        round,
        assignment: site,
        decided_ns: t_s * NS_PER_S,
    };
    let mut case = Case::new(3, Modality::Rgb);
    // Tick 2500 = 100 s: round 1's broadcast runs from 5 s.
    case.injected.insert(
        2500,
        vec![
            notice("O9", 1, Some(A), 99),  // unknown observer
            notice("O1", 2, Some(B), 99),  // wrong round
            notice("O1", 1, Some(B), 101), // from the future
            notice("O2", 1, Some(B), 1),   // before the broadcast
        ],
    );
    // Tick 0: before anything was broadcast.
    case.injected.insert(0, vec![notice("O3", 1, Some(B), 0)]);
    let r = run(&case);
    let rejected = &r.sched.stats().rejected_decisions;
    assert_eq!(rejected.get(&DecisionReject::UnknownObserver), Some(&1));
    assert_eq!(rejected.get(&DecisionReject::WrongRound), Some(&1));
    assert_eq!(rejected.get(&DecisionReject::FromTheFuture), Some(&1));
    assert_eq!(rejected.get(&DecisionReject::BeforeBroadcast), Some(&2));
    assert_eq!(r.sched.stats().rejections(), 5);
    // The mission is exactly the nominal one.
    let nominal = run(&Case::new(3, Modality::Rgb));
    assert_eq!(r.sched.stats().work_units, 6);
    assert_eq!(r.trips(), nominal.trips());
    assert_eq!(r.end, nominal.end);
}

#[test]
fn duplicates_late_decisions_and_decisions_after_the_end_are_rejected() {
    let id = |s: &str| ObserverId::new(s).unwrap();
    // O2 is black; inject a duplicate for O1 and a late decision for O2.
    let mut case = Case::new(3, Modality::Rgb);
    case.black.insert(1);
    let nominal_r1 = run(&case);
    let decided_o1 = nominal_r1
        .events()
        .find_map(|(t, e)| matches!(e, EventKind::DecisionAccepted { round: 1, .. }).then_some(t))
        .unwrap();
    let close = nominal_r1
        .events()
        .find_map(|(t, e)| matches!(e, EventKind::WindowClosed { round: 1 }).then_some(t))
        .unwrap();
    let tick = |t: u64| t / proto::TICK_NS;
    case.injected.insert(
        tick(decided_o1) + 1,
        vec![DecisionNotice {
            observer: id("O1"),
            round: 1,
            assignment: Some(B),
            decided_ns: decided_o1,
        }],
    );
    let late = close + 21 * NS_PER_S;
    case.injected.insert(
        tick(late),
        vec![DecisionNotice {
            observer: id("O2"),
            round: 1,
            assignment: Some(A),
            decided_ns: late,
        }],
    );
    let r = run(&case);
    let rejected = &r.sched.stats().rejected_decisions;
    assert_eq!(rejected.get(&DecisionReject::Duplicate), Some(&1));
    assert_eq!(rejected.get(&DecisionReject::AfterDeadline), Some(&1));
    assert_eq!(r.sched.stats().work_units, 4);

    // After the end, the scheduler keeps answering with frozen setpoints and rejects input.
    let mut s = r.sched;
    let end_tick = r.outputs.last().unwrap().tick;
    let positions = BTreeMap::new();
    let alive = Default::default();
    let d = vec![DecisionNotice {
        observer: id("O1"),
        round: 2,
        assignment: Some(B),
        decided_ns: 0,
    }];
    let out = s
        .step(&scheduler::SchedulerInput {
            clock: proto::ClockTick::at(end_tick + 1).unwrap(),
            positions_m: &positions,
            decisions: &d,
            alive: &alive,
        })
        .unwrap();
    assert!(out.session.is_empty() && out.broadcast.is_none());
    assert_eq!(out.setpoints, r.outputs.last().unwrap().setpoints);
    assert_eq!(
        s.stats()
            .rejected_decisions
            .get(&DecisionReject::MissionOver),
        Some(&1)
    );
    // Ticks must move forward; a clock with the wrong time is refused.
    let again = s.step(&scheduler::SchedulerInput {
        clock: proto::ClockTick::at(end_tick).unwrap(),
        positions_m: &positions,
        decisions: &[],
        alive: &alive,
    });
    assert!(matches!(
        again,
        Err(scheduler::SchedulerError::TickOutOfOrder { .. })
    ));
    let bad_clock = s.step(&scheduler::SchedulerInput {
        clock: proto::ClockTick {
            tick: end_tick + 5,
            sim_time_ns: 3,
        },
        positions_m: &positions,
        decisions: &[],
        alive: &alive,
    });
    assert!(matches!(
        bad_clock,
        Err(scheduler::SchedulerError::BadClock { .. })
    ));
}

#[test]
fn bad_poses_are_counted_and_ignored() {
    let mut s =
        scheduler::Scheduler::new(scheduler::SchedulerConfig::new(2, Modality::Rgb)).unwrap();
    let positions = BTreeMap::from([
        (ObserverId::new("O1").unwrap(), [f64::NAN, 0.0, 1.3]),
        (ObserverId::new("performer").unwrap(), [0.0, 0.0, 1.3]),
    ]);
    let out = s
        .step(&scheduler::SchedulerInput {
            clock: proto::ClockTick::at(0).unwrap(),
            positions_m: &positions,
            decisions: &[],
            alive: &Default::default(),
        })
        .unwrap();
    assert_eq!(s.stats().rejected_poses.values().sum::<u64>(), 2);
    assert!(
        out.setpoints
            .iter()
            .all(|p| p.kin.pos_m.iter().all(|v| v.is_finite()))
    );
    let events: Vec<_> = out.session.iter().map(|c| c.event).collect();
    assert_eq!(
        events,
        vec![
            SessionEvent::RoundReset { round: 1 },
            SessionEvent::WindowOpen { round: 1 }
        ]
    );
}

#[test]
fn no_work_on_arrival_is_logged_and_the_observer_returns() {
    // An honest observer never picks a withdrawn site, so drive O1 (N = 1, black so it never
    // decides by itself) with hand-made decisions: A in round 1 (served, A depleted), then A
    // again in round 2 against the withdrawal 010000.
    let id = ObserverId::new("O1").unwrap();
    let mut case = Case::new(1, Modality::Rgb);
    case.black.insert(0);
    let probe = {
        let mut c = case.clone();
        c.config.rounds = 1;
        run(&c)
    };
    // Round 1 broadcast final reception time, from the plan.
    let b = &probe.sched.broadcasts()[0];
    let t1 = b.scheduled[1].final_null_start_ns + harness::NULL_CONFIRM_NS;
    let k1 = t1 / proto::TICK_NS;
    case.injected.insert(
        k1,
        vec![DecisionNotice {
            observer: id.clone(),
            round: 1,
            assignment: Some(A),
            decided_ns: t1,
        }],
    );
    let r1 = run(&case);
    // Round 2 starts when O1 is back; inject a decision for the withdrawn A.
    let b2 = &r1.sched.broadcasts()[1];
    assert_eq!(r1.payloads()[1][0], "010000");
    let t2 = b2.scheduled[1].final_null_start_ns + harness::NULL_CONFIRM_NS;
    case.injected.insert(
        t2 / proto::TICK_NS,
        vec![DecisionNotice {
            observer: id,
            round: 2,
            assignment: Some(A),
            decided_ns: t2,
        }],
    );
    let r = run(&case);
    assert_eq!(r.sched.stats().work_units, 1);
    assert_eq!(r.sched.stats().no_work_arrivals, 1);
    let kinds: Vec<&EventKind> = r
        .events()
        .filter(|(_, e)| {
            matches!(
                e,
                EventKind::NoWork { .. }
                    | EventKind::ServiceStarted { .. }
                    | EventKind::ServiceEnded { .. }
            )
        })
        .map(|(_, e)| e)
        .collect();
    assert!(matches!(
        kinds[0],
        EventKind::ServiceStarted { remaining: 1, .. }
    ));
    assert!(matches!(
        kinds[1],
        EventKind::ServiceEnded { remaining: 0, .. }
    ));
    assert!(matches!(kinds[2], EventKind::NoWork { site: A, .. }));
    // The no-work trip skips the service: arrival and departure from the site coincide.
    let trips = r.trips();
    assert_eq!(trips.len(), 2);
    let served = trips[0].3 - trips[0].2;
    let unserved = trips[1].3 - trips[1].2;
    assert_eq!(served - unserved, 5 * NS_PER_S);
    check_router_and_homes(&r);
}

#[test]
fn mission_times_next_to_the_paper() {
    // Printed for the report (cargo test -- --nocapture); asserts only the structure.
    let paper: [(&str, f64, f64); 6] = [
        ("1 observer", 451.56, 475.16),
        ("2 observers", 463.16, 486.76),
        ("3 observers", 493.80, 517.40),
        ("O2 black", 454.48, 478.08),
        ("no broadcast", 15.04, 15.04),
        ("only A", 122.92, 134.76),
    ];
    let case = |name: &str, m: Modality| {
        let mut c = match name {
            "1 observer" => Case::new(1, m),
            "2 observers" => Case::new(2, m),
            _ => Case::new(3, m),
        };
        match name {
            "O2 black" => {
                c.black.insert(1);
            }
            "no broadcast" => c.config = c.config.clone().without_broadcast(),
            "only A" => c.config = c.config.clone().with_offer_sites(&[A]),
            _ => {}
        }
        c
    };
    println!("| case | ours RGB | paper RGB | ours events | paper events | units |");
    for (name, p_rgb, p_ev) in paper {
        let rgb = run(&case(name, Modality::Rgb));
        let ev = run(&case(name, Modality::Events));
        assert_eq!(rgb.sched.stats().work_units, ev.sched.stats().work_units);
        // The only modality cost is the 4 s acquisition sweep before each broadcast.
        let broadcasts = rgb.sched.broadcasts().len() as u64;
        assert_eq!(ev.sched.broadcasts().len() as u64, broadcasts);
        assert_eq!(ev.end.1 - rgb.end.1, broadcasts * 4 * NS_PER_S, "{name}");
        println!(
            "| {name} | {:.2} | {p_rgb:.2} | {:.2} | {p_ev:.2} | {} |",
            secs(rgb.end.1),
            secs(ev.end.1),
            rgb.sched.stats().work_units
        );
    }
    for m in [Modality::Rgb, Modality::Events] {
        let r = run(&Case::new(3, m));
        let latest = r.latest_final_reception_ns().unwrap();
        let first_offer = r.sched.broadcasts()[0].scheduled[0].start_ns;
        println!(
            "nominal {m:?}: first offer {:.3} s, latest final reception {:.3} s, to completion {:.3} s, total {:.3} s",
            secs(first_offer),
            secs(latest),
            secs(r.end.1 - latest),
            secs(r.end.1)
        );
        // The paper's structure: three serial round-2 trips after the latest reception (45.80 s).
        let tail_s = secs(r.end.1 - latest);
        assert!((40.0..55.0).contains(&tail_s), "{tail_s}");
        for (o, site, dep, ret) in r.trips() {
            println!(
                "  trip {o} -> {site}: {:.2} s ({:.2} → {:.2})",
                secs(ret - dep),
                secs(dep),
                secs(ret)
            );
        }
    }
}

#[test]
fn positions_come_from_sim_state_without_the_performer() {
    let pose = |name: &str, x: f64| proto::DronePose {
        name: name.to_owned(),
        pos_m: [x, 0.0, 1.3],
        quat_wxyz: [1.0, 0.0, 0.0, 0.0],
        vel_mps: [0.0; 3],
        ang_vel_radps: [0.0; 3],
    };
    let state = proto::SimState {
        tick: 1,
        stamp_ns: proto::TICK_NS,
        drones: vec![pose("performer", 0.0), pose("O2", 2.0), pose("O1", 1.0)],
    };
    let p = scheduler::observer_positions(&state);
    assert_eq!(
        p.into_iter()
            .map(|(k, v)| (k.to_string(), v[0]))
            .collect::<Vec<_>>(),
        vec![("O1".to_owned(), 1.0), ("O2".to_owned(), 2.0)]
    );
}
