//! `waggle trials` end to end on the real MuJoCo scene: the render cache replays exactly what
//! `waggle link` decodes live, seeds reproduce, bad input is refused, Ctrl-C keeps finished
//! trials.

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use serde_json::Value;

mod common;
use common::{link, payloads};

fn trials(dir: &Path, args: &[&str]) -> (Value, std::process::Output) {
    let out = waggle_tests::succeed(
        waggle_tests::waggle()
            .arg("trials")
            .args(args)
            .arg("--out")
            .arg(dir),
        &format!("waggle trials {args:?}"),
    );
    let json = std::fs::read(dir.join("trials.json")).expect("trials.json");
    (serde_json::from_slice(&json).expect("JSON"), out)
}

/// Runs `waggle ARGS`, which must fail with a message containing every one of `needles`.
fn assert_refused<S: AsRef<std::ffi::OsStr>>(args: &[S], needles: &[&str]) {
    let out = waggle_tests::waggle()
        .args(args)
        .output()
        .expect("run waggle");
    let err = String::from_utf8_lossy(&out.stderr);
    let shown: Vec<_> = args.iter().map(|a| a.as_ref().to_string_lossy()).collect();
    assert!(!out.status.success(), "waggle {shown:?} was accepted");
    for needle in needles {
        assert!(
            err.contains(needle),
            "waggle {shown:?}: no {needle:?} in {err}"
        );
    }
}

/// A fresh directory for one test (the process id keeps concurrent runs apart).
fn tmp(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("waggle-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// Zero perturbation: every trial succeeds and each observer's releases and token count equal
/// the live `waggle link` of the same condition, to the nanosecond.
fn zero_perturbation_matches_link(modality: &str, observers: &str, payload: &str) {
    let live = link(&[
        "--observers",
        observers,
        "--modality",
        modality,
        "--payload",
        payload,
    ]);
    // One directory per modality: the two zero-perturbation tests run at once.
    let dir = tmp(&format!("trials-zero-{modality}"));
    let (v, _) = trials(
        &dir,
        &[
            "--link",
            payload,
            "--observers",
            observers,
            "--modality",
            modality,
            "--trials",
            "2",
        ],
    );
    assert_eq!(v["trials"], 2);
    assert_eq!(v["successes"], 2, "{v}");
    assert_eq!(v["perturb"], serde_json::json!({}));
    assert_eq!(v["flight"], "shared");
    for t in v["per_trial"].as_array().unwrap() {
        for (name, o) in t["observers"].as_object().unwrap() {
            assert_eq!(
                o["released"],
                serde_json::json!(payloads(&live, name)),
                "{name}"
            );
            let live_release: Vec<f64> = live["observers"][name]["frames"]
                .as_array()
                .unwrap()
                .iter()
                .map(|f| f["final_null_s"].as_f64().unwrap())
                .collect();
            assert_eq!(o["release_s"], serde_json::json!(live_release), "{name}");
            assert_eq!(
                o["tokens"].as_u64().unwrap() as usize,
                live["observers"][name]["tokens"].as_array().unwrap().len(),
                "{name}"
            );
            assert_eq!(o["messages_lost"], 0);
        }
    }
}

#[test]
fn zero_perturbation_events_trials_equal_the_live_link() {
    zero_perturbation_matches_link("events", "2", "011010");
}

#[test]
fn zero_perturbation_rgb_trials_equal_the_live_link() {
    zero_perturbation_matches_link("rgb", "1", "100111");
}

#[test]
fn same_seed_gives_identical_trials_json_whatever_the_jobs_and_seeds_change_the_noise() {
    let common = [
        "--link",
        "011010",
        "--observers",
        "1",
        "--modality",
        "events",
        "--trials",
        "3",
        "--perturb",
        "events.shot_noise_hz=0.2",
        "--perturb",
        "link.drop_rate=0.05",
    ];
    let (a, b, c) = (tmp("trials-a"), tmp("trials-b"), tmp("trials-c"));
    // The flight is the same for all three (sensor and link terms only): the first run flies
    // it into a render cache and the others read it (≈ 25 of this test's 48 s saved), so the
    // second run also checks that a cached flight gives the same trials.json as a fresh one.
    let cache = tmp("trials-cache");
    let cached = ["--render-cache", cache.to_str().unwrap()];
    let (va, _) = trials(
        &a,
        &[&common[..], &["--seed", "7", "--jobs", "1"], &cached].concat(),
    );
    let (_, _) = trials(
        &b,
        &[&common[..], &["--seed", "7", "--jobs", "2"], &cached].concat(),
    );
    assert_eq!(
        std::fs::read(a.join("trials.json")).unwrap(),
        std::fs::read(b.join("trials.json")).unwrap(),
        "same seed, different --jobs, fresh and cached flight: trials.json differs"
    );
    let (vc, _) = trials(&c, &[&common[..], &["--seed", "8"], &cached].concat());
    let lost = |v: &Value| -> Vec<u64> {
        v["per_trial"]
            .as_array()
            .unwrap()
            .iter()
            .map(|t| t["observers"]["O1"]["messages_lost"].as_u64().unwrap())
            .collect()
    };
    assert!(lost(&va).iter().all(|&n| n > 0), "{:?}", lost(&va));
    assert_ne!(lost(&va), lost(&vc), "seeds 7 and 8 drew the same losses");
    assert_eq!(va["perturb"]["link.drop_rate"], 0.05);
    let ci = va["ci95"].as_array().unwrap();
    assert!(ci[0].as_f64().unwrap() <= ci[1].as_f64().unwrap());
}

#[test]
fn bad_perturbations_and_counts_are_refused_naming_the_input() {
    let dir = tmp("trials-bad");
    for (args, needle) in [
        (
            vec!["--perturb", "events.shot_noise=1"],
            "events.shot_noise",
        ),
        (vec!["--perturb", "link.drop_rate=-0.5"], "link.drop_rate"),
        (vec!["--perturb", "rgb.read_noise_grey"], "KEY=VALUE"),
        (vec!["--trials", "0"], "--trials"),
        (vec!["--sensor-preset", "v2e-loud"], "v2e-loud"),
        (
            vec![
                "--sensor-preset",
                "v2e-noisy",
                "--perturb",
                "events.threshold=5",
            ],
            "events.threshold",
        ),
    ] {
        let out = dir.to_string_lossy();
        let base = [
            "trials",
            "--link",
            "011010",
            "--modality",
            "events",
            "--out",
            &out,
        ];
        assert_refused(&[&base[..], &args[..]].concat(), &[needle]);
    }
    assert!(!dir.join("trials.json").exists());
}

#[test]
fn ctrl_c_keeps_the_finished_trials() {
    let dir = tmp("trials-int");
    let mut child = waggle_tests::waggle()
        .args([
            "trials",
            "--link",
            "011010",
            "--observers",
            "1",
            "--modality",
            "rgb",
            "--trials",
            "1000",
            "--jobs",
            "1",
            "--perturb",
            "rgb.read_noise_grey=2",
            "--out",
        ])
        .arg(&dir)
        .stderr(std::process::Stdio::null())
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Interrupt once a trial has finished (its record is written as it ends), not after a
    // fixed time: on a machine busy with other tests a trial can take longer than any guess.
    let waiting = Instant::now();
    while std::fs::read_dir(dir.join("trials")).map_or(0, |d| d.count()) == 0 {
        assert!(
            waiting.elapsed() < Duration::from_secs(900),
            "no trial finished in 900 s"
        );
        assert!(child.try_wait().unwrap().is_none(), "exited before a trial");
        std::thread::sleep(Duration::from_millis(250));
    }
    Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    let started = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "no exit after SIGINT"
        );
        std::thread::sleep(Duration::from_millis(200));
    };
    assert!(!status.success(), "an interrupted run must not exit 0");
    let v: Value =
        serde_json::from_slice(&std::fs::read(dir.join("trials.json")).unwrap()).unwrap();
    assert_eq!(v["interrupted"], true);
    let n = v["trials"].as_u64().unwrap();
    assert!((1..1000).contains(&n), "{n} trials kept");
    assert_eq!(v["per_trial"].as_array().unwrap().len() as u64, n);
}

fn read_json(path: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(path).expect("read")).expect("JSON")
}

#[test]
fn mission_trials_are_seeded_gusts_change_them_and_the_criterion_is_the_case() {
    let (a, b, c) = (tmp("ct-a"), tmp("ct-b"), tmp("ct-c"));
    let args = [
        "--case",
        "nominal-3",
        "--modality",
        "ideal",
        "--trials",
        "3",
        "--perturb",
        "flight.gust_sigma_n=0.02",
    ];
    trials(&a, &[&args[..], &["--seed", "3", "--jobs", "1"]].concat());
    trials(&b, &[&args[..], &["--seed", "3", "--jobs", "2"]].concat());
    assert_eq!(
        std::fs::read(a.join("trials.json")).unwrap(),
        std::fs::read(b.join("trials.json")).unwrap()
    );
    trials(&c, &[&args[..], &["--seed", "4"]].concat());
    let va = read_json(&a.join("trials.json"));
    let vc = read_json(&c.join("trials.json"));
    let outcome = |v: &Value| -> Vec<String> {
        v["per_trial"]
            .as_array()
            .unwrap()
            .iter()
            .map(|t| format!("{} {}", t["metrics"]["completion_time_s"], t["observers"]))
            .collect()
    };
    assert_ne!(
        outcome(&va),
        outcome(&vc),
        "seeds 3 and 4 flew the same gusts"
    );
    assert!(va["criterion"].as_str().unwrap().contains("nominal-3"));
    // Unperturbed, the ideal receiver meets the case: the criterion can pass.
    let d = tmp("ct-d");
    let (vd, _) = trials(
        &d,
        &[
            "--case",
            "nominal-3",
            "--modality",
            "ideal",
            "--trials",
            "1",
        ],
    );
    assert_eq!(vd["successes"], 1, "{vd}");
    let m = &vd["per_trial"][0]["metrics"];
    assert_eq!(m["work_units"], 6);
    assert_eq!(m["unserved_capacity"], 0);
    assert!(m["broadcast_symbols"].as_u64().unwrap() > 0);
    // The two observers that served A in round 1 are reassigned to B after its withdrawal.
    let r = m["reassignments"].as_array().unwrap();
    assert_eq!(r.len(), 2, "{m}");
    assert!(
        r.iter()
            .all(|x| x["went_to"] == "B" && x["delay_s"].as_f64().unwrap() > 0.0)
    );
}

#[test]
fn the_fixed_allocation_baseline_reads_nothing_and_wastes_trips_on_a_withdrawn_site() {
    let dir = tmp("ct-fixed");
    let (v, _) = trials(
        &dir,
        &[
            "--case",
            "nominal-3",
            "--modality",
            "ideal",
            "--policy",
            "fixed",
            "--trials",
            "1",
        ],
    );
    assert_eq!(
        v["successes"], 0,
        "the paper's expected outcome needs communication"
    );
    let t = &v["per_trial"][0];
    let m = &t["metrics"];
    assert_eq!(m["policy"], "fixed");
    assert_eq!(m["broadcast_symbols"], 0);
    // O1 and O3 take A every round: A's two units in round 1, then two trips to a depleted A.
    assert_eq!(m["work_units"], 4);
    assert_eq!(m["wasted_trips"], 2);
    assert_eq!(m["unserved_capacity"], 2);
    let r = m["reassignments"].as_array().unwrap();
    assert!(
        r.iter()
            .all(|x| x["went_to"] == "A" && x["delay_s"].is_null()),
        "{m}"
    );
    for o in ["O1", "O2", "O3"] {
        assert_eq!(t["observers"][o]["complete_messages"], 0);
    }
}

#[test]
fn mission_trials_refuse_what_a_mission_does_not_model() {
    let dir = tmp("ct-refuse");
    let out = dir.to_string_lossy();
    assert_refused(
        &[
            "trials",
            "--case",
            "nominal-3",
            "--modality",
            "ideal",
            "--out",
            &out,
            "--perturb",
            "geometry.position_sigma_m=0.05",
        ],
        &["geometry.position_sigma_m"],
    );
    // Link trials need a sensor.
    assert_refused(
        &[
            "trials",
            "--link",
            "011010",
            "--modality",
            "ideal",
            "--out",
            &out,
        ],
        &["sensor"],
    );
}

#[test]
fn a_study_of_both_modalities_shares_one_flight_per_level_and_writes_its_report() {
    let dir = tmp("study");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("tiny.toml");
    std::fs::write(
        &file,
        r#"
name = "tiny"
modalities = ["rgb", "events"]
link = ["011010"]
observers = 1
trials = 2
seed = 5
criterion = "exact-payloads"
[[vary]]
key = "events.shot_noise_hz"
levels = [0.0, 0.0003]
"#,
    )
    .unwrap();
    let out = dir.join("out");
    let run = waggle_tests::waggle()
        .arg("study")
        .arg(&file)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let points = read_json(&out.join("study.json"));
    assert_eq!(points.as_array().unwrap().len(), 4);
    for p in points.as_array().unwrap() {
        if p["level"] == 0.0 {
            assert_eq!(p["successes"], 2, "{p}");
        }
        let dir = out.join(p["dir"].as_str().unwrap());
        // Every point replayed the level's one flight (acquisition sweep for both modalities).
        assert_eq!(read_json(&dir.join("cost.json"))["flights"], 0, "{p}");
        assert_eq!(read_json(&dir.join("trials.json"))["flight"], "shared");
    }
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        report.contains("### rgb") && report.contains("### events"),
        "{report}"
    );
    assert!(
        std::fs::read_to_string(out.join("success-events.shot_noise_hz.svg"))
            .unwrap()
            .contains("<svg")
    );
    // A bad level is refused at load, naming it, before anything runs.
    let bad = dir.join("bad.toml");
    let text = std::fs::read_to_string(&file)
        .unwrap()
        .replace("0.0003]", "-1.0]");
    std::fs::write(&bad, text).unwrap();
    assert_refused(
        &[
            std::ffi::OsStr::new("study"),
            bad.as_os_str(),
            std::ffi::OsStr::new("--out"),
            dir.join("bad-out").as_os_str(),
        ],
        &["events.shot_noise_hz", "-1"],
    );
    assert!(!dir.join("bad-out").exists());
}

#[test]
fn re_flown_trials_render_on_parallel_threads_and_stay_identical_across_jobs() {
    let args = [
        "--link",
        "011010",
        "--observers",
        "1",
        "--modality",
        "rgb",
        "--trials",
        "2",
        "--perturb",
        "geometry.yaw_sigma_deg=1",
        "--perturb",
        "geometry.position_sigma_m=0.02",
    ];
    let (a, b) = (tmp("refly-a"), tmp("refly-b"));
    let (va, _) = trials(&a, &[&args[..], &["--jobs", "2"]].concat());
    trials(&b, &[&args[..], &["--jobs", "1"]].concat());
    assert_eq!(va["flight"], "per trial");
    assert_eq!(
        read_json(&a.join("cost.json"))["flights"],
        3,
        "one per trial + the nominal one"
    );
    assert_eq!(
        std::fs::read(a.join("trials.json")).unwrap(),
        std::fs::read(b.join("trials.json")).unwrap()
    );
}

#[test]
fn wind_and_the_cascade_fly_in_missions_and_link_trials_with_their_tracking_measured() {
    let tracking = |v: &Value| v["per_trial"][0]["metrics"]["performer_tracking"].clone();
    // Still air, ideal stabilisation: no tracking field (outputs as before).
    let calm = tmp("air-calm");
    let (v, _) = trials(
        &calm,
        &["--case", "only-a", "--modality", "ideal", "--trials", "1"],
    );
    assert!(tracking(&v).is_null(), "{v}");
    // A steady 1 m/s wind under ideal stabilisation: millimetres of error, still a pass.
    let windy = tmp("air-wind");
    let wind = ["--perturb", "wind.mean_mps=1"];
    let (v, _) = trials(
        &windy,
        &[
            &["--case", "only-a", "--modality", "ideal", "--trials", "1"][..],
            &wind,
        ]
        .concat(),
    );
    let t = tracking(&v);
    let (rms_m, max_m) = (t["rms_m"].as_f64().unwrap(), t["max_m"].as_f64().unwrap());
    assert!(rms_m > 1e-4 && max_m < 0.02 && rms_m <= max_m, "{t}");
    assert_eq!(v["successes"], 1, "{v}");
    // The cascade with its noisy estimate tracks worse than the ideal controller in the same air.
    let cascade = tmp("air-cascade");
    let (vc, _) = trials(
        &cascade,
        &[
            &["--case", "only-a", "--modality", "ideal", "--trials", "1"][..],
            &wind,
            &["--perturb", "flight.cascade=1"],
        ]
        .concat(),
    );
    assert!(
        tracking(&vc)["rms_m"].as_f64().unwrap() > 3.0 * rms_m,
        "{vc}"
    );
    // Link trials re-fly each trial in its own wind: two seeds, two flights.
    let (a, b) = (tmp("air-link-a"), tmp("air-link-b"));
    let link = [
        "--link",
        "011010",
        "--observers",
        "1",
        "--modality",
        "rgb",
        "--trials",
        "1",
        "--perturb",
        "wind.mean_mps=1",
        "--perturb",
        "wind.sigma_mps=0.3",
    ];
    let (va, _) = trials(&a, &[&link[..], &["--seed", "1"]].concat());
    let (vb, _) = trials(&b, &[&link[..], &["--seed", "2"]].concat());
    assert_ne!(
        va["per_trial"], vb["per_trial"],
        "two seeds flew the same wind"
    );
}
