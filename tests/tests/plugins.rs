//! Receivers of one's own (`waggle trials --receiver python:MODULE:CLASS`), run by the same
//! trials as Waggle's: a plug-in in a worker process of the Python package built by the setup
//! (`python/`), on the test venv's interpreter.
//!
//! - Waggle's own event receiver wrapped as a Python plug-in (`python/examples`) gives the
//!   native run's `trials.json`, byte for byte, under a sensor preset, on a viewpoint, payload
//!   and seed no other test uses; its core-seconds per trial are reported beside the native's.
//! - A tracker written from scratch in plain numpy decodes a clean link through Waggle's
//!   segmenter and parser.
//! - Plug-ins that raise, return malformed output, exit or hang fail their own trials with the
//!   reason recorded (a hang as `timed-out`, the run marked not reproducible); the run ends with
//!   its `trials.json`. One that cannot be loaded fails the run before any trial, naming it.
//! - In whole missions (`--receiver O2=python:…`): the wrapped event receiver gives the golden
//!   `observers.json` of `only-a`, as processes under the observers' access lists and in one
//!   process; a plug-in that hangs leaves its observer deaf, the mission ends with its summary
//!   and the failure named; an unknown observer, one named twice and a plug-in that cannot be
//!   loaded are refused before anything flies.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

mod golden_runs;

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("waggle-plugins-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// `waggle trials` with the plug-ins' folders on `PYTHONPATH` and the venv's interpreter.
fn trials(args: &[&str], out: &Path) -> Command {
    let mut cmd = with_plugins(waggle_tests::waggle());
    cmd.arg("trials").args(args).arg("--out").arg(out);
    cmd
}

/// `cmd` with the plug-ins' folders on `PYTHONPATH` and the venv's interpreter.
fn with_plugins(mut cmd: Command) -> Command {
    let root = waggle_tests::workspace_root();
    let path = std::env::join_paths([root.join("python/examples"), root.join("tests/plugins")])
        .expect("plug-in folders");
    cmd.env("WAGGLE_PYTHON", waggle_tests::venv_python_with("waggle"))
        .env("PYTHONPATH", path);
    cmd
}

fn read_json(path: &Path) -> Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).expect("JSON")
}

/// Core-seconds per trial of a finished run (`cost.json`).
fn core_s_per_trial(dir: &Path) -> f64 {
    let cost = read_json(&dir.join("cost.json"));
    cost["cpu_s"].as_f64().expect("cpu_s") / cost["trials_run"].as_f64().expect("trials_run")
}

const LINK: [&str; 10] = [
    "--link",
    "100101",
    "--viewpoint=-14,6,1.45",
    "--trials",
    "3",
    "--seed",
    "41",
    "--jobs",
    "2",
    "--acquisition=true",
];

#[test]
fn waggles_own_receivers_wrapped_as_plugins_score_as_themselves() {
    for (modality, class, preset) in [
        ("events", "WaggleEvents", "v2e-default"),
        ("rgb", "WaggleRgb", "v2e-default"),
    ] {
        let native = scratch(&format!("native-{modality}"));
        let wrapped = scratch(&format!("wrapped-{modality}"));
        let common: Vec<&str> = LINK
            .iter()
            .copied()
            .chain(["--modality", modality, "--sensor-preset", preset])
            .collect();
        waggle_tests::succeed(&mut trials(&common, &native), "waggle trials (native)");
        let receiver = format!("python:wrapped_waggle:{class}");
        let mut with_plugin = common.clone();
        with_plugin.extend(["--receiver", &receiver]);
        waggle_tests::succeed(
            &mut trials(&with_plugin, &wrapped),
            "waggle trials (wrapped)",
        );
        let a = std::fs::read(native.join("trials.json")).unwrap();
        let b = std::fs::read(wrapped.join("trials.json")).unwrap();
        assert!(
            a == b,
            "{modality}: the wrapped receiver's trials.json differs from the native run's"
        );
        let ratio = core_s_per_trial(&wrapped) / core_s_per_trial(&native);
        eprintln!(
            "{modality}: wrapped/native core-seconds per trial {ratio:.2} ({:.2} / {:.2})",
            core_s_per_trial(&wrapped),
            core_s_per_trial(&native)
        );
        let out = read_json(&native.join("trials.json"));
        assert!(out["successes"].as_u64().unwrap() > 0, "{modality}: {out}");
        for dir in [native, wrapped] {
            let _ = std::fs::remove_dir_all(dir);
        }
    }
}

#[test]
fn a_numpy_tracker_from_scratch_decodes_a_clean_link() {
    let dir = scratch("numpy");
    let args = [
        "--link",
        "011001",
        "--viewpoint=9,2,1.6",
        "--modality",
        "events",
        "--trials",
        "2",
        "--receiver",
        "python:numpy_tracker:CentroidTracker",
    ];
    waggle_tests::succeed(&mut trials(&args, &dir), "waggle trials (numpy tracker)");
    let out = read_json(&dir.join("trials.json"));
    assert_eq!(out["successes"], 2, "{out}");
    assert_eq!(
        out["per_trial"][0]["observers"]["O1"]["released"][0],
        "011001"
    );
    let _ = std::fs::remove_dir_all(dir);
}

/// One run of a misbehaving plug-in: its `trials.json`.
fn misbehaving(class: &str, extra: &[&str], cache: &Path) -> Value {
    let dir = scratch(class);
    let receiver = format!("python:faulty_plugins:{class}");
    let mut args = vec![
        "--link",
        "110100",
        "--viewpoint=4,3,1.5",
        "--modality",
        "events",
        "--trials",
        "4",
        "--seed",
        "7",
        "--receiver",
        &receiver,
        "--render-cache",
        cache.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    waggle_tests::succeed(
        &mut trials(&args, &dir),
        &format!("waggle trials ({class})"),
    );
    let out = read_json(&dir.join("trials.json"));
    let _ = std::fs::remove_dir_all(dir);
    out
}

fn reasons(out: &Value) -> Vec<String> {
    out["per_trial"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|r| r["plugin_failure"]["reason"].as_str().map(str::to_owned))
        .collect()
}

#[test]
fn misbehaving_plugins_fail_only_their_own_trials() {
    let cache = scratch("cache");
    // Raises in the trials whose seed has bit 7 set: those fail, the others are scored.
    let out = misbehaving("RaisesOnTrialOne", &[], &cache);
    let failed = out["summary"]["plugin_failed"].as_u64().unwrap_or(0);
    let raising = out["per_trial"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|r| (r["seed"].as_u64().unwrap() >> 7) & 1 == 1)
        .count() as u64;
    assert_eq!(failed, raising, "{out}");
    assert!(failed > 0 && failed < 4, "{out}");
    assert_eq!(out["trials"], 4);
    assert!(
        reasons(&out)
            .iter()
            .all(|r| r.contains("ZeroDivisionError") && r.contains("faulty_plugins.py")),
        "{out}"
    );
    assert!(out["summary"].get("reproducible").is_none());
    for (class, why) in [
        ("Malformed", "(x_px, y_px) or None"),
        ("NotFinite", "not finite"),
        ("BadTokens", "'BIT2'"),
        ("TokenFromTheFuture", "no token comes after its input"),
        ("Exits", "exit status: 3"),
        ("NoLevel", "level is None"),
    ] {
        let out = misbehaving(class, &[], &cache);
        assert_eq!(out["summary"]["plugin_failed"], 4, "{class}: {out}");
        assert_eq!(out["successes"], 0, "{class}");
        let reasons = reasons(&out);
        assert!(
            reasons.iter().all(|r| r.contains(why)),
            "{class}: {reasons:?}"
        );
    }
    // Printing is harmless: standard output never reaches the pipe.
    let out = misbehaving("Prints", &[], &cache);
    assert!(out["summary"].get("plugin_failed").is_none(), "{out}");
    // A hang is cut at the limit and recorded as its own outcome.
    let out = misbehaving("Hangs", &["--plugin-time-limit-s", "2"], &cache);
    assert_eq!(out["summary"]["plugin_timed_out"], 4, "{out}");
    assert_eq!(out["summary"]["reproducible"], false);
    assert!(
        reasons(&out)
            .iter()
            .all(|r| r.contains("time limit of 2 s"))
    );
    let _ = std::fs::remove_dir_all(cache);
}

#[test]
fn a_plugin_that_cannot_be_loaded_or_named_fails_the_run_naming_it() {
    for (receiver, why) in [
        ("python:no_such_module_here:Receiver", "no_such_module_here"),
        ("python:faulty_plugins:NoSuchClass", "NoSuchClass"),
        (
            "python:faulty-plugins:X",
            "MODULE is not a dotted Python name",
        ),
        ("faulty_plugins:X", "python:MODULE:CLASS"),
    ] {
        let dir = scratch("unloadable");
        let args = [
            "--link",
            "110100",
            "--modality",
            "events",
            "--trials",
            "1",
            "--receiver",
            receiver,
        ];
        let out = trials(&args, &dir).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{receiver}");
        assert!(stderr.contains(why), "{receiver}: {stderr}");
        assert!(!dir.join("trials.json").exists());
        let _ = std::fs::remove_dir_all(dir);
    }
}

#[test]
fn a_study_compares_receivers_side_by_side_on_the_same_trials() {
    let root = waggle_tests::workspace_root();
    let out = scratch("study");
    let path = std::env::join_paths([root.join("python/examples")]).unwrap();
    waggle_tests::succeed(
        waggle_tests::waggle()
            .arg("study")
            .arg(root.join("python/examples/compare-receivers.toml"))
            .arg("--out")
            .arg(&out)
            .env("WAGGLE_PYTHON", waggle_tests::venv_python_with("waggle"))
            .env("PYTHONPATH", path),
        "waggle study compare-receivers",
    );
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    for series in [
        "### events\n",
        "### events · python:wrapped_waggle:WaggleEvents\n",
        "### events · python:numpy_tracker:CentroidTracker\n",
    ] {
        assert!(report.contains(series), "{series} missing from:\n{report}");
    }
    let cost = std::fs::read_to_string(out.join("cost.md")).unwrap();
    assert!(
        cost.contains("events · python:numpy_tracker:CentroidTracker"),
        "{cost}"
    );
    // Waggle's receiver wrapped scores exactly as itself, point by point.
    for level in ["0", "25"] {
        let native = std::fs::read(out.join(format!("events-{level}/trials.json"))).unwrap();
        let wrapped =
            std::fs::read(out.join(format!("events-WaggleEvents-{level}/trials.json"))).unwrap();
        assert!(
            native == wrapped,
            "azimuth {level}: the wrapped receiver's trials differ"
        );
    }
    let _ = std::fs::remove_dir_all(out);
}

/// `waggle inputs` streams trial k's inputs exactly as `waggle trials` gives them to its
/// receivers: Waggle's receivers fed the stream from Python decode what trial k recorded.
#[test]
fn a_trials_inputs_streamed_to_python_decode_as_the_trial_did() {
    let dir = scratch("inputs");
    std::fs::create_dir_all(&dir).unwrap();
    for (modality, preset) in [("events", "v2e-noisy"), ("rgb", "v2e-default")] {
        let condition = [
            "--link",
            "101100",
            "--viewpoint=31,2,1.7",
            "--viewpoint=-8,5,1.4",
            "--modality",
            modality,
            "--seed",
            "29",
            "--sensor-preset",
            preset,
            "--perturb",
            "link.drop_rate=0.05",
        ];
        let runs = dir.join(format!("trials-{modality}"));
        let mut args = condition.to_vec();
        args.extend(["--trials", "2"]);
        waggle_tests::succeed(&mut trials(&args, &runs), "waggle trials");
        let record = &read_json(&runs.join("trials.json"))["per_trial"][1];
        let stream = dir.join(format!("trial1-{modality}.bin"));
        waggle_tests::succeed(
            waggle_tests::waggle()
                .arg("inputs")
                .args(condition)
                .args(["--trial", "1", "--out"])
                .arg(&stream),
            "waggle inputs",
        );
        let out = waggle_tests::succeed(
            Command::new(waggle_tests::venv_python_with("waggle"))
                .arg(waggle_tests::workspace_root().join("tests/plugins/decode_inputs.py"))
                .arg(&stream),
            "decode_inputs.py",
        );
        let got: Value = serde_json::from_slice(&out.stdout).expect("JSON");
        for name in ["O1", "O2"] {
            let want = &record["observers"][name];
            let have = &got["observers"][name];
            assert_eq!(have["released"], want["released"], "{modality} {name}");
            assert_eq!(have["tokens"], want["tokens"], "{modality} {name}");
            // The link lost some messages: the stream holds only what the receiver got.
            let kept = want["messages"].as_u64().unwrap() - want["messages_lost"].as_u64().unwrap();
            assert_eq!(have["ticks"].as_u64(), Some(kept), "{modality} {name}");
            assert!(want["messages_lost"].as_u64().unwrap() > 0);
            if modality == "events" {
                assert_eq!(have["events_received"], want["events_received"], "{name}");
            }
            assert!(
                have["seen"].as_u64().unwrap() > kept / 2,
                "{modality} {name}: {have}"
            );
        }
        assert_eq!(got["labels_match_timeline"], true);
        assert!(got["symbols"].as_array().unwrap().len() >= 5, "{got}");
    }
    // A cut stream is refused, naming what is wrong.
    let whole = std::fs::read(dir.join("trial1-events.bin")).unwrap();
    let cut = dir.join("cut.bin");
    std::fs::write(&cut, &whole[..whole.len() / 2]).unwrap();
    let out = Command::new(waggle_tests::venv_python_with("waggle"))
        .arg(waggle_tests::workspace_root().join("tests/plugins/decode_inputs.py"))
        .arg(&cut)
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("InputsError"));
    let _ = std::fs::remove_dir_all(dir);
}

/// The wrapped event receiver as O2's receiver in a whole `only-a` mission gives the golden
/// `observers.json`: as processes (its own observer process, behind its access list, starts
/// and feeds the worker) and in one process (`waggle mission`).
#[test]
fn a_whole_mission_with_the_wrapped_receiver_is_golden() {
    let golden = golden_runs::golden_entry("only-a", "events");
    let want = golden["observers_sha256"]
        .as_str()
        .expect("observers_sha256");
    let receiver = "O2=python:wrapped_waggle:WaggleEvents";
    let dir = scratch("mission-run");
    let mut run = with_plugins(waggle_tests::waggle_with_nodes());
    run.args([
        "run",
        "only-a",
        "--modality",
        "events",
        "--observer-acl",
        "--quiet",
    ])
    .args(["--receiver", receiver, "--no-record", "--out"])
    .arg(&dir);
    waggle_tests::succeed(&mut run, "waggle run only-a with a plug-in receiver");
    let bytes = std::fs::read(dir.join("observers.json")).expect("observers.json");
    assert_eq!(golden_runs::sha256_hex(&bytes), want, "waggle run");
    let log = |o: &str| std::fs::read_to_string(dir.join(format!("logs/observer-{o}.log")));
    let plugged = "python:wrapped_waggle:WaggleEvents";
    assert!(
        log("O2").expect("O2's log").contains(plugged),
        "O2 ran the plug-in"
    );
    assert!(!log("O1").expect("O1's log").contains(plugged));
    let _ = std::fs::remove_dir_all(&dir);

    let dir = scratch("mission-in-process");
    let mut mission = with_plugins(waggle_tests::waggle());
    mission
        .args(["mission", "only-a", "--receiver", receiver, "--out"])
        .arg(&dir);
    waggle_tests::succeed(
        &mut mission,
        "waggle mission only-a with a plug-in receiver",
    );
    let bytes = std::fs::read(dir.join("observers.json")).expect("observers.json");
    assert_eq!(golden_runs::sha256_hex(&bytes), want, "waggle mission");
    let _ = std::fs::remove_dir_all(dir);
}

/// A plug-in that hangs leaves its observer deaf: the mission still ends with its summary, the
/// other observers decode, and the failure is named; bad `--receiver` values are refused
/// before anything flies.
#[test]
fn a_failing_plugin_in_a_mission_is_named_and_bad_receivers_are_refused() {
    let out = with_plugins(waggle_tests::waggle())
        .args(["mission", "only-a", "--json", "--plugin-time-limit-s", "2"])
        .args(["--receiver", "O2=python:faulty_plugins:Hangs"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "O2 heard nothing: {stderr}");
    assert!(
        stderr.contains("O2's receiver failed")
            && stderr.contains("timed-out")
            && stderr.contains("time limit of 2 s"),
        "{stderr}"
    );
    let summary: Value = serde_json::from_slice(&out.stdout).expect("the summary, as JSON");
    let messages: Vec<u64> = summary["observers"]
        .as_object()
        .expect("observers")
        .values()
        .map(|o| o["complete_messages"].as_u64().expect("complete_messages"))
        .collect();
    assert_eq!(messages, [1, 0, 1], "{summary}");

    for (args, why) in [
        (&["O9=python:faulty_plugins:Malformed"][..], "O9"),
        (
            &[
                "O2=python:faulty_plugins:Malformed",
                "O2=python:faulty_plugins:Exits",
            ],
            "more than once",
        ),
        (&["O2=python:no_such_module_here:R"], "no_such_module_here"),
        (&["O2=faulty_plugins:R"], "python:MODULE:CLASS"),
    ] {
        for command in ["mission", "run"] {
            let mut cmd = with_plugins(waggle_tests::waggle_with_nodes());
            cmd.args([command, "only-a", "--modality", "events"]);
            if command == "run" {
                cmd.args(["--quiet", "--no-record"]);
            }
            for a in args {
                cmd.args(["--receiver", a]);
            }
            let out = cmd.output().unwrap();
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert!(!out.status.success(), "{command} {args:?}");
            assert!(stderr.contains(why), "{command} {args:?}: {stderr}");
            assert!(
                !stderr.contains("FAIL") && out.stdout.is_empty(),
                "{command} {args:?} was refused before flying: {stderr}"
            );
        }
    }
}

/// The package's own tests (`python/tests`, run by pytest on the venv's CPython): its
/// receivers, arrays, recordings read into numpy and errors, from Python.
#[test]
fn the_python_packages_own_tests_pass() {
    let root = waggle_tests::workspace_root();
    let out = waggle_tests::succeed(
        Command::new(waggle_tests::venv_python_with("waggle"))
            .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
            .arg(root.join("python/tests"))
            .current_dir(&root),
        "python -m pytest python/tests",
    );
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(
        said.contains(" passed") && !said.contains("skipped"),
        "every test ran: {said}"
    );
}
