//! The mission summary shared by `waggle mission` (in-process), `waggle run` (distributed) and
//! `waggle audit` (from a recording): per-observer messages, payloads, decisions and services,
//! the provenance audit, the check against the case's expected outcome and the printed table.

use std::collections::{BTreeMap, BTreeSet};

use proto::{Decision, ObserverId};
use serde::Serialize;

use run_format::case::Case;
use run_format::run_dir::{
    FalseRelease, MissionSummary, ObserverSummary, ObserverViewpoint, OfferReception,
};
// `ns_s` and `decision_label` format `ObserverSummary::from_record`'s fields, so they live
// with it in `run-format`; re-exported here for the readers that print them.
pub use run_format::run_dir::{decision_label, ns_s};

/// How a summary prints its receiver.
pub fn receiver_text(r: Option<proto::Receiver>) -> &'static str {
    r.map_or("modality not recorded", proto::Receiver::as_str)
}

/// How a summary prints its end reason.
pub fn end_reason_text(r: Option<proto::EndReason>) -> &'static str {
    r.map_or("none (no mission report)", proto::EndReason::as_str)
}

/// Each observer's viewpoint in the built-in formation of `n` observers (empty for a count
/// outside 1..=8).
pub fn viewpoints(n: usize) -> BTreeMap<String, ObserverViewpoint> {
    let Ok(formation) = proto::scene::Formation::standard(n) else {
        return BTreeMap::new();
    };
    formation
        .placements()
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let rise_m = p.home_m[2] - proto::scene::PERFORMER_HOVER_M[2];
            let view = ObserverViewpoint {
                viewing_angle_deg: round_to(p.viewing_angle_rad().to_degrees(), 0.1),
                distance_m: round_to(p.distance_m(), 0.001),
                elevation_deg: round_to((rise_m / p.distance_m()).asin().to_degrees(), 0.1),
            };
            (proto::scene::observer_name(i), view)
        })
        .collect()
}

fn round_to(v: f64, step: f64) -> f64 {
    (v / step).round() * step
}

/// Observers that released no frame while at least one other released some.
pub fn deaf_observers(observers: &BTreeMap<String, ObserverSummary>) -> Vec<String> {
    if observers.values().all(|o| o.payloads.is_empty()) {
        return Vec::new();
    }
    observers
        .iter()
        .filter(|(_, o)| o.payloads.is_empty())
        .map(|(name, _)| name.clone())
        .collect()
}

/// Fills the summary's viewpoints (formation of `n` observers) and deaf observers.
pub fn annotate(s: &mut MissionSummary, n: usize) {
    s.deaf_observers = deaf_observers(&s.observers);
    s.viewpoints = viewpoints(n);
}

/// The mission summary's derived fields for a flown case: viewpoints, deaf observers, router.
pub fn annotate_case(s: &mut MissionSummary, case: &Case) {
    annotate(s, case.observers);
    s.flights = case.flights;
}

/// The warning naming deaf observers with their viewpoints, if any.
pub fn deaf_warning(
    deaf: &[String],
    viewpoints: &BTreeMap<String, ObserverViewpoint>,
) -> Option<String> {
    if deaf.is_empty() {
        return None;
    }
    let named: Vec<String> = deaf
        .iter()
        .map(|o| match viewpoints.get(o) {
            Some(v) => format!(
                "{o} (viewing angle {:.0}°, {:.2} m)",
                v.viewing_angle_deg, v.distance_m
            ),
            None => o.clone(),
        })
        .collect();
    Some(format!(
        "released no frame while others did: {}",
        named.join(", ")
    ))
}

/// Why `s` misses `case`'s expected outcome (empty: it meets it).
pub fn check_expected(case: &Case, s: &MissionSummary) -> Vec<String> {
    let mut reasons = Vec::new();
    let got: Vec<usize> = s.observers.values().map(|o| o.complete_messages).collect();
    if got != case.expected.messages {
        reasons.push(format!(
            "complete messages {got:?}, expected {:?}",
            case.expected.messages
        ));
    }
    if s.work_units != case.expected.work_units {
        reasons.push(format!(
            "{} work units, expected {}",
            s.work_units, case.expected.work_units
        ));
    }
    for (o, want) in &case.expected.services {
        let have = s
            .observers
            .get(o)
            .map(|x| x.services.clone())
            .unwrap_or_default();
        if &have != want {
            reasons.push(format!("{o} served {have:?}, expected {want:?}"));
        }
    }
    if s.contact_steps != 0 {
        reasons.push(format!("{} contact steps", s.contact_steps));
    }
    reasons.extend(s.false_releases.iter().map(|f| {
        format!(
            "false release: {} released {} in round {}, the performer flew {}",
            f.observer,
            f.released,
            f.round,
            if f.flown.is_empty() {
                "nothing".to_owned()
            } else {
                f.flown.join(",")
            }
        )
    }));
    reasons.extend(
        s.provenance_violations
            .iter()
            .map(|v| format!("provenance: {v}")),
    );
    reasons
}

/// Prints the summary table (`waggle mission`, `waggle run`).
pub fn print_summary(s: &MissionSummary) {
    println!(
        "case {} ({}) — {}: mission time {:.2} s ({}), {:.1} s wall",
        s.case,
        receiver_text(s.modality),
        if s.pass { "PASS" } else { "FAIL" },
        s.mission_time_s,
        end_reason_text(s.end_reason),
        s.wall_seconds
    );
    println!(
        "{:<4} {:>13} {:>9} {:>24} {:>12} {:>10}",
        "obs", "view", "messages", "payloads", "decisions", "services"
    );
    for (name, o) in &s.observers {
        let view = s.viewpoints.get(name).map_or(String::new(), |v| {
            format!("{:.0}° {:.2} m", v.viewing_angle_deg, v.distance_m)
        });
        println!(
            "{name:<4} {view:>13} {:>9} {:>24} {:>12} {:>10}",
            o.complete_messages,
            o.payloads.join(","),
            o.decisions.join(","),
            o.services.join(",")
        );
    }
    println!(
        "work units {} · contact steps {} · minimum separation {:.3} m · provenance violations {} · \
         {} flights",
        s.work_units,
        s.contact_steps,
        s.min_separation_m,
        s.provenance_violations.len(),
        s.flights
    );
    if let Some(w) = deaf_warning(&s.deaf_observers, &s.viewpoints) {
        println!("  ⚠ {w}");
    }
    for r in &s.reasons {
        println!("  ✗ {r}");
    }
}

/// What the performer flew in each round (payloads in order), from the scheduler's broadcasts.
pub fn flown_payloads<'a>(
    broadcasts: impl IntoIterator<Item = &'a proto::Broadcast>,
) -> BTreeMap<u32, Vec<u8>> {
    let mut flown: BTreeMap<u32, Vec<u8>> = BTreeMap::new();
    for b in broadcasts {
        // A round that flew its broadcast again flew each offer once more, not a new one.
        let round = flown.entry(b.round).or_default();
        for p in b.offers.iter().map(proto::Offer::to_payload) {
            if !round.contains(&p) {
                round.push(p);
            }
        }
    }
    flown
}

/// The released frames whose payload was not flown in their round, observer by observer in
/// release order (`frames`: each observer's frames, in order). A round whose broadcast is not
/// known (a cut recording) is not judged.
pub fn false_releases<'a>(
    frames: impl IntoIterator<Item = &'a proto::FrameEvent>,
    flown: &BTreeMap<u32, Vec<u8>>,
) -> Vec<FalseRelease> {
    let bits = |p: &u8| format!("{p:06b}");
    let mut out: Vec<FalseRelease> = frames
        .into_iter()
        .filter_map(|f| {
            let payloads = flown.get(&f.round)?;
            (!payloads.contains(&f.frame.payload)).then(|| FalseRelease {
                observer: f.observer.to_string(),
                round: f.round,
                released: bits(&f.frame.payload),
                flown: payloads.iter().map(bits).collect(),
            })
        })
        .collect();
    out.sort_by(|a, b| a.observer.cmp(&b.observer));
    out
}

/// What became of each offer flown to each of `observers` (by name): received in its round, or
/// lost (an offer flown again by a repeated broadcast counts once); with the observer's false releases (`false_releases`' output) counted apart. Only
/// rounds whose broadcast is known count.
pub fn offer_receptions<'a>(
    observers: &[String],
    frames: impl IntoIterator<Item = &'a proto::FrameEvent>,
    flown: &BTreeMap<u32, Vec<u8>>,
    false_releases: &[FalseRelease],
) -> BTreeMap<String, OfferReception> {
    let mut released: BTreeMap<(String, u32), Vec<u8>> = BTreeMap::new();
    for f in frames {
        released
            .entry((f.observer.to_string(), f.round))
            .or_default()
            .push(f.frame.payload);
    }
    observers
        .iter()
        .map(|o| {
            let mut r = OfferReception::default();
            for (round, payloads) in flown {
                let got = released.get(&(o.clone(), *round));
                // A repeated broadcast flies the round's offers again: each offer counts once,
                // received if any of its flyings was released.
                let offers: BTreeSet<&u8> = payloads.iter().collect();
                for p in offers {
                    r.flown += 1;
                    if got.is_some_and(|g| g.contains(p)) {
                        r.received += 1;
                    } else {
                        r.lost += 1;
                    }
                }
            }
            r.false_releases = false_releases.iter().filter(|f| &f.observer == o).count() as u64;
            (o.clone(), r)
        })
        .collect()
}

/// The provenance audit of every accepted assignment against its departure time.
pub fn provenance_violations(
    decisions: &[Decision],
    departures: &BTreeMap<(ObserverId, u32), u64>,
) -> Vec<String> {
    decisions
        .iter()
        .filter(|d| d.assignment.is_some())
        .filter_map(|d| {
            let dep = departures.get(&(d.observer.clone(), d.round))?;
            proto::audit_assignment(d, *dep)
                .err()
                .map(|v| v.to_string())
        })
        .collect()
}

/// Prints `value` as pretty JSON on stdout; a closed pipe (`| head`) is an error, not a panic.
pub fn print_json(value: &impl Serialize) -> anyhow::Result<()> {
    use std::io::Write as _;
    writeln!(
        std::io::stdout().lock(),
        "{}",
        serde_json::to_string_pretty(value)?
    )?;
    Ok(())
}

/// `messages dropped: 0`, or the total and each process's counts by key and reason.
pub fn rejects_line(rejects: &BTreeMap<String, Vec<proto::RejectCount>>) -> String {
    let total: u64 = rejects.values().flatten().map(|c| c.count).sum();
    if total == 0 {
        return format!("messages dropped: 0 ({} processes reported)", rejects.len());
    }
    let parts: Vec<String> = rejects
        .iter()
        .filter(|(_, c)| !c.is_empty())
        .map(|(p, counts)| {
            let each: Vec<String> = counts
                .iter()
                .map(|c| format!("{} {} ×{}", c.key, c.reason, c.count))
                .collect();
            format!("{p}: {}", each.join(", "))
        })
        .collect();
    format!("messages dropped: {total} — {}", parts.join(" · "))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::{Broadcast, FrameEvent, Offer, ReleasedFrame, Site};

    fn frame(observer: &str, seq: u64, round: u32, payload: u8) -> FrameEvent {
        FrameEvent {
            observer: ObserverId::new(observer).unwrap(),
            seq,
            round,
            frame: ReleasedFrame {
                payload,
                token_stamps_ns: vec![0; 17],
            },
        }
    }

    #[test]
    fn an_offer_flown_again_counts_once() {
        let (pa, pb) = (0b010000, 0b100111);
        // Round 2 flown twice (a repeat): O1 released each offer once, O2 only `pa`, twice.
        let flown = BTreeMap::from([(2, vec![pa, pb, pa, pb])]);
        let frames = [
            frame("O1", 1, 2, pa),
            frame("O1", 2, 2, pb),
            frame("O2", 1, 2, pa),
            frame("O2", 2, 2, pa),
        ];
        let observers = ["O1".to_owned(), "O2".to_owned()];
        let got = offer_receptions(&observers, &frames, &flown, &[]);
        let counts = |o: &str| (got[o].flown, got[o].received, got[o].lost);
        assert_eq!(counts("O1"), (2, 2, 0));
        assert_eq!(counts("O2"), (2, 1, 1));
    }

    #[test]
    fn a_release_not_flown_in_its_round_is_named_and_fails_the_mission() {
        let a = Offer::new(Site::A, 2, 1).unwrap();
        let withdrawn = Offer::withdrawal(Site::A);
        let broadcast = |round, offers: Vec<Offer>| Broadcast {
            tick: u64::from(round),
            round,
            start_ns: 0,
            offers,
            acquisition: false,
        };
        let flown = flown_payloads(&[
            broadcast(1, vec![a]),
            broadcast(2, vec![withdrawn]),
            broadcast(3, vec![]),
        ]);
        let (pa, pw) = (a.to_payload(), withdrawn.to_payload());
        let frames = [
            frame("O2", 0, 1, pa),
            frame("O2", 1, 2, pa), // round 1's offer read again in round 2: false
            frame("O1", 0, 2, pw),
            frame("O1", 1, 3, pw), // nothing was flown in round 3
            frame("O1", 2, 4, pa), // round 4's broadcast is unknown: not judged
        ];
        let found = false_releases(&frames, &flown);
        let named: Vec<(&str, u32, &str)> = found
            .iter()
            .map(|f| (f.observer.as_str(), f.round, f.released.as_str()))
            .collect();
        let (bits_a, bits_w) = (format!("{pa:06b}"), format!("{pw:06b}"));
        assert_eq!(
            named,
            [("O1", 3, bits_w.as_str()), ("O2", 2, bits_a.as_str())]
        );
        assert_eq!(found[1].flown, std::slice::from_ref(&bits_w));
        assert!(found[0].flown.is_empty());

        let mut summary: MissionSummary = serde_json::from_str(
            r#"{"case":"only-a","modality":"events","observers":{},"work_units":0,
                "mission_time_s":1.0,"end_reason":null,"contact_steps":0,
                "min_separation_m":1.0,"provenance_violations":[],"pass":true,
                "reasons":[],"wall_seconds":1.0}"#,
        )
        .unwrap();
        let clean = serde_json::to_string(&summary).unwrap();
        assert!(!clean.contains("false_releases"), "omitted when none");
        summary.false_releases = found;
        let case = run_format::case::Case::load("only-a").unwrap();
        let reasons = check_expected(&case, &summary);
        assert!(
            reasons.iter().any(|r| r
                == &format!(
                    "false release: O2 released {bits_a} in round 2, the performer flew {bits_w}"
                )),
            "{reasons:?}"
        );
        assert!(reasons.iter().any(|r| r.contains("flew nothing")));

        let observers = ["O1".to_owned(), "O2".to_owned(), "O3".to_owned()];
        let got = offer_receptions(&observers, &frames, &flown, &summary.false_releases);
        let counts = |o: &str| {
            let r = got[o];
            (r.flown, r.received, r.lost, r.false_releases)
        };
        assert_eq!(counts("O1"), (2, 1, 1, 1), "round 2's withdrawal received");
        assert_eq!(counts("O2"), (2, 1, 1, 1), "round 1's offer received");
        assert_eq!(counts("O3"), (2, 0, 2, 0), "deaf: everything lost");
    }
}
