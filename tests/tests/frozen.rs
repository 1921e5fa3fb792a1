//! Frozen behaviour: `waggle run` reproduces, byte for byte, its golden runs.
//!
//! `tests/golden/frozen.toml` holds, per (case, modality), the SHA-256 of `observers.json` (every
//! token with its confirmation time, every frame, every decision) and the summary's
//! `sensor_digests` (a digest of every sensor packet each camera published), for each renderer:
//! `[[run]]` for the default (Waggle's renderer), `[[reference]]` for MuJoCo's, recorded when
//! its cameras rendered every full frame. Any change to physics, rendering, the event camera,
//! perception, the scheduler or the wire shows up here. MuJoCo's damage path must match the
//! reference, and `only-a` is also run with `--render full` in both modalities, so MuJoCo's two
//! render paths are checked equal on whole runs. In the default suite: `only-a` in both
//! modalities with the default renderer (≈ 20 s each) and with MuJoCo's damage path in events
//! (≈ 1 min); the rest is `#[ignore]`d (`deploy/test.sh --full`).
//!
//! `waggle mission` runs the same observer core in one process and must write the very same
//! `observers.json` as the processes: `only-a` with event cameras in the default suite, the
//! other golden cases (`only-a` with RGB too, since 2026-11-30: the default run keeps its golden
//! as processes, here and in `tests/compose.rs`) under `--full`.
//!
//! The SHA-256 comes from the `sha2` crate rather than a `sha256sum` child process: it adds one
//! small crate (its `digest` and `cpufeatures` dependencies are already in the tree) and keeps
//! the test free of any assumption about the host's coreutils.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::Stdio;
use std::sync::Mutex;

use deploy::run_dir::RunSummary;
use proto::RenderPath;
use waggle_tests::waggle_with_nodes;

mod golden_runs;
use golden_runs::{golden_entry, golden_entry_of, golden_of, sha256_hex};

/// One run at a time: each already keeps both cores busy, and two at once would only invite the
/// wall-clock grace period into a test that must be exact.
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

/// Runs `waggle run CASE --modality M` and compares its outputs with the golden entry. The output
/// directory is kept when they differ, for a diff against a run of the old tree.
fn assert_frozen(case: &str, modality: &str, render: RenderPath) {
    let want = golden_entry_of(render, case, modality);
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir: PathBuf = std::env::temp_dir().join(format!(
        "waggle-frozen-{}-{case}-{modality}-{render}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    let out = waggle_with_nodes()
        .args([
            "run",
            case,
            "--modality",
            modality,
            "--render",
            render.as_str(),
            "--out",
        ])
        .arg(&dir)
        .arg("--quiet")
        .stdin(Stdio::null())
        .output()
        .expect("run waggle");
    let context = || {
        format!(
            "{case} ({modality}, --render {render}), outputs in {}\nstatus {}\nstderr:\n{}\n\
             what the observers judged missing, and why:\n{}",
            dir.display(),
            out.status,
            String::from_utf8_lossy(&out.stderr),
            missing_packet_lines(&dir)
        )
    };
    let read =
        |f: &str| std::fs::read(dir.join(f)).unwrap_or_else(|e| panic!("{f}: {e}\n{}", context()));

    let summary: RunSummary = serde_json::from_slice(&read("summary.json"))
        .unwrap_or_else(|e| panic!("summary.json is not a RunSummary ({e})\n{}", context()));
    assert_eq!(summary.render, render, "{}", context());
    for (o, r) in &summary.camera_renders {
        match render {
            RenderPath::Full => assert!(r.damage == 0 && r.skipped == 0, "{o}: {r:?}"),
            // Both shortcuts must have been taken for the comparison to mean anything.
            RenderPath::Damage => assert!(
                r.damage > 0 && r.skipped + r.damage > r.full && r.scissored,
                "{o}: {r:?}\n{}",
                context()
            ),
            // Raster's damage renders are not scissored (it touches only the rectangle's pixels).
            RenderPath::Raster => assert!(
                r.damage > 0 && r.skipped + r.damage > r.full,
                "{o}: {r:?}\n{}",
                context()
            ),
        }
    }
    assert!(
        summary
            .camera_renders
            .keys()
            .eq(summary.sensor_digests.keys()),
        "every camera that published reports its renders\n{}",
        context()
    );
    let got_digests: BTreeMap<String, String> = summary.sensor_digests;
    let want_digests: BTreeMap<String, String> = want["sensor_digests"]
        .as_table()
        .expect("sensor_digests table")
        .iter()
        .map(|(o, d)| (o.clone(), d.as_str().unwrap().to_string()))
        .collect();
    assert_eq!(
        got_digests,
        want_digests,
        "sensor digests changed\n{}",
        context()
    );

    let got_sha = sha256_hex(&read("observers.json"));
    assert_eq!(
        got_sha,
        want["observers_sha256"].as_str().unwrap(),
        "observers.json changed\n{}",
        context()
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The observers' log lines about missing packets (at most 20 per observer): when a golden run
/// differs on a machine where it cannot be rerun (CI), these say whether a verdict was taken by
/// the wall clock ("grace period expired"), a lost camera, or a notice.
fn missing_packet_lines(dir: &std::path::Path) -> String {
    let mut out = String::new();
    for o in ["O1", "O2", "O3"] {
        let log =
            std::fs::read_to_string(dir.join(format!("logs/observer-{o}.log"))).unwrap_or_default();
        for line in log
            .lines()
            .filter(|l| l.contains("missing") || l.contains("WARN") || l.contains("ERROR"))
            .take(20)
        {
            out.push_str(&format!("{o}: {line}\n"));
        }
    }
    if out.is_empty() {
        out.push_str("(none logged)\n");
    }
    out
}

/// Runs `waggle mission CASE --modality M --out DIR` and compares its `observers.json` with the
/// golden entry of `waggle run`'s.
fn assert_mission_matches_run(case: &str, modality: &str) {
    let want = golden_entry(case, modality);
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir: PathBuf = std::env::temp_dir().join(format!(
        "waggle-frozen-mission-{}-{case}-{modality}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    let out = waggle_tests::waggle()
        .args(["mission", case, "--modality", modality, "--json", "--out"])
        .arg(&dir)
        .stdin(Stdio::null())
        .output()
        .expect("run waggle");
    let observers = std::fs::read(dir.join("observers.json")).unwrap_or_else(|e| {
        panic!(
            "{case} ({modality}): no observers.json ({e}); status {}\n{}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        )
    });
    assert_eq!(
        sha256_hex(&observers),
        want["observers_sha256"].as_str().unwrap(),
        "waggle mission {case} --modality {modality} differs from waggle run's golden \
         observers.json (outputs in {})",
        dir.display()
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn mission_only_a_events_writes_the_runs_observers_json() {
    assert_mission_matches_run("only-a", "events");
}

#[test]
#[ignore = "whole mission in one process, ≈ 1.5 min: deploy/test.sh --full (the default run \
            checks the mission path on only-a events and the only-a rgb golden as processes, \
            here and in tests/compose.rs)"]
fn mission_only_a_rgb_writes_the_runs_observers_json() {
    assert_mission_matches_run("only-a", "rgb");
}

#[test]
#[ignore = "whole mission in one process, ≈ 4 min: deploy/test.sh --full"]
fn mission_nominal_3_events_writes_the_runs_observers_json() {
    assert_mission_matches_run("nominal-3", "events");
}

#[test]
#[ignore = "whole mission in one process, ≈ 2 min: deploy/test.sh --full"]
fn mission_nominal_3_rgb_writes_the_runs_observers_json() {
    assert_mission_matches_run("nominal-3", "rgb");
}

#[test]
#[ignore = "whole mission in one process, ≈ 4 min: deploy/test.sh --full"]
fn mission_dropout_o2_events_writes_the_runs_observers_json() {
    assert_mission_matches_run("dropout-o2", "events");
}

/// The (case, modality) pairs with a test below; every golden entry must have one.
const TESTED: [(&str, &str); 5] = [
    ("only-a", "events"),
    ("only-a", "rgb"),
    ("nominal-3", "events"),
    ("nominal-3", "rgb"),
    ("dropout-o2", "events"),
];

#[test]
fn every_golden_run_has_a_test() {
    let mut tested: Vec<(String, String)> = TESTED
        .iter()
        .map(|(c, m)| (c.to_string(), m.to_string()))
        .collect();
    tested.sort();
    // Both renderers' tables hold the same runs, each with a test of its own below.
    for render in [RenderPath::Raster, RenderPath::Damage] {
        let mut listed: Vec<(String, String)> = golden_of(render)
            .iter()
            .map(|r| {
                (
                    r["case"].as_str().unwrap().to_string(),
                    r["modality"].as_str().unwrap().to_string(),
                )
            })
            .collect();
        listed.sort();
        assert_eq!(listed, tested, "{render}");
    }
    assert_eq!(sha256_hex(b"abc")[..16], *"ba7816bf8f01cfea");
}

#[test]
fn only_a_events_is_frozen() {
    assert_frozen("only-a", "events", RenderPath::Raster);
}

#[test]
fn only_a_rgb_is_frozen() {
    assert_frozen("only-a", "rgb", RenderPath::Raster);
}

#[test]
fn only_a_events_with_mujoco_is_frozen() {
    assert_frozen("only-a", "events", RenderPath::Damage);
}

#[test]
#[ignore = "MuJoCo's renderer as processes, ≈ 1 min: deploy/test.sh --full"]
fn only_a_rgb_with_mujoco_is_frozen() {
    assert_frozen("only-a", "rgb", RenderPath::Damage);
}

#[test]
#[ignore = "MuJoCo's whole-frame reference path as processes, ≈ 45 s (libs/sim/tests/damage.rs \
            checks the damage path against it frame by frame in the default suite): \
            deploy/test.sh --full"]
fn only_a_events_full_render_is_frozen() {
    assert_frozen("only-a", "events", RenderPath::Full);
}

#[test]
#[ignore = "MuJoCo's whole-frame reference path as processes, ≈ 45 s (libs/sim/tests/damage.rs \
            checks the damage path against it frame by frame in the default suite): \
            deploy/test.sh --full"]
fn only_a_rgb_full_render_is_frozen() {
    assert_frozen("only-a", "rgb", RenderPath::Full);
}

#[test]
#[ignore = "whole mission, ≈ 2 min: deploy/test.sh --full"]
fn nominal_3_events_is_frozen() {
    assert_frozen("nominal-3", "events", RenderPath::Raster);
}

#[test]
#[ignore = "whole mission, ≈ 1.5 min: deploy/test.sh --full"]
fn nominal_3_rgb_is_frozen() {
    assert_frozen("nominal-3", "rgb", RenderPath::Raster);
}

#[test]
#[ignore = "whole mission, ≈ 1 min: deploy/test.sh --full"]
fn dropout_o2_events_is_frozen() {
    assert_frozen("dropout-o2", "events", RenderPath::Raster);
}

#[test]
#[ignore = "whole mission with MuJoCo's renderer, ≈ 5 min: deploy/test.sh --full"]
fn nominal_3_events_with_mujoco_is_frozen() {
    assert_frozen("nominal-3", "events", RenderPath::Damage);
}

#[test]
#[ignore = "whole mission with MuJoCo's renderer, ≈ 5 min: deploy/test.sh --full"]
fn nominal_3_rgb_with_mujoco_is_frozen() {
    assert_frozen("nominal-3", "rgb", RenderPath::Damage);
}

#[test]
#[ignore = "whole mission with MuJoCo's renderer, ≈ 4 min: deploy/test.sh --full"]
fn dropout_o2_events_with_mujoco_is_frozen() {
    assert_frozen("dropout-o2", "events", RenderPath::Damage);
}
