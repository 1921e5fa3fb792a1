//! `waggle mission`: whole cases in one process on the real MuJoCo scene.
//!
//! Proves every case meets the outcome its case file expects (with the ideal receiver, and with
//! event cameras in the long tests), that nominal-3 allocates as in the paper, that the negative
//! controls leave observers inactive, that a mission is deterministic, and that an unmet
//! expectation fails with its reason.
//!
//! The ideal-receiver runs are fast and in the default suite; the sensor runs render every
//! camera for the whole mission (≈ 8–12 min each on 2 cores) and are `#[ignore]`d — run them
//! with `deploy/test.sh --full` (or `cargo test --release -p waggle-tests --test mission -- --ignored`).

use serde_json::Value;
use waggle_tests::waggle;

fn mission(case: &str, modality: &str) -> (bool, Value) {
    let out = waggle()
        .args(["mission", case, "--modality", modality, "--json"])
        .output()
        .expect("run waggle");
    let v: Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "{case}: no JSON ({e}): {}",
            String::from_utf8_lossy(&out.stderr)
        )
    });
    (out.status.success(), v)
}

fn assert_passes(case: &str, modality: &str) -> Value {
    let (ok, v) = mission(case, modality);
    assert!(
        ok && v["pass"] == true,
        "{case} ({modality}) failed: {:#}",
        v["reasons"]
    );
    assert_eq!(v["contact_steps"], 0);
    assert!(v["provenance_violations"].as_array().unwrap().is_empty());
    v
}

#[test]
fn every_case_meets_its_expected_outcome_with_the_ideal_receiver() {
    for (case, _) in deploy::case::BUILT_IN {
        let v = assert_passes(case, "ideal");
        println!(
            "{case}: {:.2} s, {} units",
            v["mission_time_s"].as_f64().unwrap(),
            v["work_units"]
        );
    }
}

#[test]
fn nominal_mission_allocates_as_in_the_paper_and_everyone_comes_home() {
    let v = assert_passes("nominal-3", "ideal");
    assert_eq!(v["work_units"], 6);
    assert_eq!(v["end_reason"], "RoundsComplete");
    for (o, want) in [
        ("O1", ["r1:A", "r2:B"]),
        ("O2", ["r1:A", "r2:B"]),
        ("O3", ["r1:B", "r2:B"]),
    ] {
        assert_eq!(
            v["observers"][o]["decisions"],
            serde_json::json!(want),
            "{o}"
        );
        assert_eq!(
            v["observers"][o]["payloads"],
            serde_json::json!(["011010", "100111", "010000", "100111"])
        );
    }
}

#[test]
fn negative_controls_leave_observers_inactive() {
    let v = assert_passes("no-broadcast", "ideal");
    assert_eq!(v["end_reason"], "NoBroadcast");
    let v = assert_passes("only-a", "ideal");
    assert_eq!(v["end_reason"], "NoDecision");
    for o in ["O1", "O2", "O3"] {
        assert!(
            v["observers"][o]["decisions"]
                .as_array()
                .unwrap()
                .is_empty(),
            "{o} decided on one offer"
        );
        assert!(v["observers"][o]["services"].as_array().unwrap().is_empty());
    }
}

#[test]
fn the_same_case_twice_gives_identical_tokens_times_decisions_and_work() {
    let strip = |mut v: Value| {
        v.as_object_mut().unwrap().remove("wall_seconds");
        v
    };
    let a = strip(assert_passes("black-o2", "ideal"));
    let b = strip(assert_passes("black-o2", "ideal"));
    assert_eq!(a, b);
}

#[test]
fn a_case_file_with_an_unmet_expectation_fails_with_the_reason() {
    let dir = std::env::temp_dir().join(format!("waggle-mission-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("wrong.toml");
    std::fs::write(
        &path,
        "name = \"wrong\"\nobservers = 1\n[expected]\nmessages = [4]\nwork_units = 3\nservices = { O1 = [\"A\", \"B\"] }\n",
    )
    .unwrap();
    let (ok, v) = mission(path.to_str().unwrap(), "ideal");
    assert!(!ok);
    assert_eq!(v["pass"], false);
    assert!(
        v["reasons"][0]
            .as_str()
            .unwrap()
            .contains("2 work units, expected 3"),
        "{v}"
    );
}

/// Groups of 4, 6 and 8 in the two-row formation: with the ideal receiver every observer
/// releases every frame, nobody is flagged deaf, every viewpoint is inside the 40° cone and
/// the 0.35 m separation holds.
#[test]
fn every_observer_of_the_group_cases_decodes_every_frame() {
    for (case, n) in [
        ("four-observers", 4),
        ("six-observers", 6),
        ("eight-observers", 8),
    ] {
        let v = assert_passes(case, "ideal");
        let obs = v["observers"].as_object().unwrap();
        assert_eq!(obs.len(), n);
        for (name, o) in obs {
            assert_eq!(o["complete_messages"], 4, "{case} {name}");
            let angle = v["viewpoints"][name]["viewing_angle_deg"].as_f64().unwrap();
            assert!(angle <= 40.0, "{case} {name} at {angle}°");
        }
        assert!(v["deaf_observers"].as_array().unwrap().is_empty());
        assert!(v["min_separation_m"].as_f64().unwrap() >= 0.35, "{case}");
    }
}

/// Any group size and offer order: five observers (both rows) offered B before A. The ideal
/// receiver's outcome becomes the case's expectation, which the event cameras must then meet
/// (≈ 6 min: 5 cameras rendered in one process for ≈ 520 s of sim).
/// The concurrent router in physics: eight observers' trips overlap, the case's outcome is
/// unchanged, no contact, the simulator's separation stays ≥ 0.35 m, and it ends sooner.
#[test]
fn eight_observers_with_concurrent_flights_keep_separation_and_finish_sooner() {
    let out = waggle()
        .args([
            "mission",
            "eight-observers",
            "--modality",
            "ideal",
            "--flights",
            "concurrent",
            "--json",
        ])
        .output()
        .expect("run waggle");
    let con: Value = serde_json::from_slice(&out.stdout).expect("JSON");
    assert!(
        out.status.success() && con["pass"] == true,
        "{:#}",
        con["reasons"]
    );
    assert_eq!(con["flights"], "concurrent");
    assert_eq!(con["contact_steps"], 0);
    assert!(con["min_separation_m"].as_f64().unwrap() >= 0.35);
    let seq = assert_passes("eight-observers", "ideal");
    assert_eq!(seq["flights"], "sequential");
    let (t_con, t_seq) = (
        con["mission_time_s"].as_f64().unwrap(),
        seq["mission_time_s"].as_f64().unwrap(),
    );
    assert!(
        t_con + 60.0 < t_seq,
        "concurrent {t_con} s vs sequential {t_seq} s"
    );
}

#[test]
#[ignore = "renders 5 event cameras for ~520 s of sim, ≈ 6 min; run with --ignored"]
fn five_observers_offered_b_then_a_serve_the_same_with_event_cameras_as_ideal() {
    let dir = std::env::temp_dir().join(format!("waggle-five-ba-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let case = |expected: &str| {
        let path = dir.join("five-ba.toml");
        std::fs::write(
            &path,
            format!(
                "name = \"five-ba\"\nobservers = 5\noffer_sites = [\"B\", \"A\"]\n\
                 modalities = [\"events\"]\n[expected]\n{expected}"
            ),
        )
        .unwrap();
        path.to_str().unwrap().to_owned()
    };
    let open = case("messages = [4, 4, 4, 4, 4]\nwork_units = 0\nservices = {}\n");
    let (_, ideal) = mission(&open, "ideal");
    let services: Vec<String> = ideal["observers"]
        .as_object()
        .unwrap()
        .iter()
        .map(|(o, v)| {
            let sites: Vec<String> = v["services"]
                .as_array()
                .unwrap()
                .iter()
                .map(|s| format!("{s}"))
                .collect();
            format!("{o} = [{}]", sites.join(", "))
        })
        .collect();
    let expected = format!(
        "messages = [4, 4, 4, 4, 4]\nwork_units = {}\nservices = {{ {} }}\n",
        ideal["work_units"],
        services.join(", ")
    );
    let path = case(&expected);
    assert_passes(&path, "ideal");
    let v = assert_passes(&path, "events");
    assert!(v["deaf_observers"].as_array().unwrap().is_empty());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
#[ignore = "renders 3 cameras at 100 Hz for ~480 s of sim: minutes; run with --ignored"]
fn nominal_3_with_event_cameras() {
    let v = assert_passes("nominal-3", "events");
    assert_eq!(v["work_units"], 6);
}

#[test]
#[ignore = "renders 3 cameras for ~480 s of sim: minutes; run with --ignored"]
fn dropout_o2_with_event_cameras() {
    let v = assert_passes("dropout-o2", "events");
    assert!(
        v["observers"]["O2"]["services"]
            .as_array()
            .unwrap()
            .is_empty()
    );
}

#[test]
#[ignore = "renders 3 cameras for ~480 s of sim: minutes; run with --ignored"]
fn every_event_case_meets_its_expected_outcome() {
    for case in [
        "one-observer",
        "two-observers",
        "black-o2",
        "no-broadcast",
        "only-a",
    ] {
        assert_passes(case, "events");
    }
}
