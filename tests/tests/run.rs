//! `waggle run`: whole cases as separate processes over Zenoh.
//!
//! Proves the launcher runs every node as its own process in lockstep, that each exits cleanly,
//! that Ctrl-C stops every child and still leaves a summary and a whole recording, that a killed
//! camera (dropout) and a throttled one lose exactly the packets they should, and that two runs
//! of the same case are identical even behind the observer ACL.
//!
//! The launcher starts the node binaries found next to `waggle`, so build them first:
//!
//! ```text
//! cargo build --release --workspace --bins
//! cargo test --release -p waggle-tests --test run                 # the short tests (≈ 30 s)
//! cargo test --release -p waggle-tests --test run -- --ignored    # whole missions (≈ 30 min on 2 cores)
//! ```

use std::path::PathBuf;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use std::collections::BTreeMap;

use deploy::run_dir::{ObserverRecord, RunSummary};
use serde_json::Value;
use waggle_tests::{export_ros2, spawn_background_run, waggle, waggle_with_nodes};

fn out_dir(name: &str) -> PathBuf {
    let dir = out_dir_path(name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// Where [`out_dir`] puts run `name`.
fn out_dir_path(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("waggle-run-test-{}-{name}", std::process::id()))
}

struct Run {
    output: Output,
    summary: RunSummary,
    observers: BTreeMap<String, ObserverRecord>,
}

fn run(case: &str, modality: &str, name: &str, extra: &[&str]) -> Run {
    let dir = out_dir(name);
    let output = waggle_with_nodes()
        .args(["run", case, "--modality", modality, "--quiet", "--out"])
        .arg(&dir)
        .args(extra)
        .stdin(Stdio::null())
        .output()
        .unwrap();
    let read = |f: &str| -> String {
        let path = dir.join(f);
        std::fs::read_to_string(&path).unwrap_or_else(|e| {
            panic!(
                "{}: {e}\nstdout:\n{}\nstderr:\n{}",
                path.display(),
                String::from_utf8_lossy(&output.stdout),
                String::from_utf8_lossy(&output.stderr)
            )
        })
    };
    Run {
        summary: serde_json::from_str(&read("summary.json")).expect("summary.json is a RunSummary"),
        observers: serde_json::from_str(&read("observers.json"))
            .expect("observers.json maps observers to ObserverRecord"),
        output,
    }
}

impl Run {
    fn assert_pass(&self) {
        assert!(
            self.output.status.success() && self.summary.mission.pass,
            "stdout:\n{}\nstderr:\n{}\nsummary: {:#?}",
            String::from_utf8_lossy(&self.output.stdout),
            String::from_utf8_lossy(&self.output.stderr),
            self.summary
        );
    }

    fn messages(&self) -> Vec<usize> {
        self.summary
            .mission
            .observers
            .values()
            .map(|o| o.complete_messages)
            .collect()
    }

    fn services(&self, o: &str) -> Vec<String> {
        self.summary.mission.observers[o].services.clone()
    }

    fn every_process_exited_cleanly(&self) {
        for (name, p) in &self.summary.processes {
            if !p.killed_by_fault {
                assert_eq!(p.exit, "exit 0", "{name}: {p:?}");
            }
        }
    }
}

/// Session ids of every process still running whose command line names `session`.
fn processes_of(session: &str) -> Vec<String> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir("/proc").unwrap().flatten() {
        let cmdline = std::fs::read(entry.path().join("cmdline")).unwrap_or_default();
        let text = String::from_utf8_lossy(&cmdline).replace('\0', " ");
        if text.contains(session) && !text.contains("cargo") {
            out.push(format!("{}: {text}", entry.file_name().to_string_lossy()));
        }
    }
    out
}

/// The no-broadcast case (15 s of sim time) also samples memory every 10 sim seconds: rss.csv
/// has a column per process, the launcher's included, and rows at 0 and 10 s.
#[test]
fn no_broadcast_runs_as_separate_processes_in_lockstep() {
    let r = run(
        "no-broadcast",
        "events",
        "no-broadcast",
        &["--rss-every-s", "10"],
    );
    r.assert_pass();
    let (names, rows) =
        deploy::launch::rss::read(&out_dir_path("no-broadcast").join("rss.csv")).unwrap();
    let mut want: Vec<String> = r.summary.processes.keys().cloned().collect();
    want.push("launcher".into());
    want.sort();
    assert_eq!(names, want);
    assert_eq!(rows.iter().map(|(s, _)| *s).collect::<Vec<_>>(), [0, 10]);
    for (sim_s, kb) in &rows {
        // Every process was running at both samples, each with some memory.
        assert!(
            kb.iter().all(|k| k.is_some_and(|k| k > 1000)),
            "{sim_s} s: {kb:?}"
        );
    }
    r.every_process_exited_cleanly();
    assert_eq!(r.messages(), [0, 0, 0]);
    assert_eq!(r.summary.mission.work_units, 0);
    assert_eq!(r.summary.mission.mission_time_s, 15.0);
    assert_eq!(
        r.summary.mission.end_reason,
        Some(proto::EndReason::NoBroadcast)
    );
    assert_eq!(r.summary.mission.contact_steps, 0);
    assert!(r.summary.missing_packets.is_empty());
    // One packet per tick 1..=375 from every camera, none dropped.
    for o in ["O1", "O2", "O3"] {
        let d = r.summary.sensor_digests[o].as_str();
        assert!(d.starts_with("packets=375 dropped=0 digest="), "{o}: {d}");
        assert!(r.summary.home_error_m[o] < 0.01);
    }
    for p in ["sim", "scheduler", "performer", "camera-O1", "observer-O3"] {
        assert!(r.summary.processes[p].cpu_s > 0.0, "{p}");
    }
    assert!(r.observers["O1"].tokens.is_empty());
}

/// `waggle replay FILE --json`: its report (exit 0 required: every decode reproduced).
fn replay_json(file: &std::path::Path) -> Value {
    let out = waggle()
        .arg("replay")
        .arg(file)
        .arg("--json")
        .output()
        .unwrap();
    let v: Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "{}: {e}: {}",
            file.display(),
            String::from_utf8_lossy(&out.stderr)
        );
    });
    assert!(out.status.success(), "{}: {v:#}", file.display());
    v
}

#[test]
fn a_sensor_preset_reaches_the_camera_processes_and_the_summary_records_it() {
    // A throttled and a blacked-out camera too: the recording keeps the sensors' input (the
    // default with a noise model), and the replay must regenerate exactly the packets each
    // camera published, dropped ones left out.
    let r = run(
        "no-broadcast",
        "events",
        "sensor-preset",
        &[
            "--sensor-preset",
            "v2e-default",
            "--perturb",
            "events.shot_noise_hz=0.01",
            "--seed",
            "3",
            "--throttle",
            "O1@2:300:0",
            "--black",
            "O2",
        ],
    );
    r.assert_pass();
    let recording = out_dir_path("sensor-preset").join("session.mcap");
    let v = replay_json(&recording);
    assert_eq!(v["partial"], false, "{v:#}");
    assert_eq!(v["all_matched"], true, "{v:#}");
    for o in ["O1", "O2"] {
        let g = &v["observers"][o]["regenerated"];
        assert_eq!(g["made"], g["received"], "{o}: {g:#}");
        assert_eq!(g["unassembled"], 0, "{o}: {g:#}");
        assert!(g["made"]["events"].as_u64().unwrap() > 0, "{o}: {g:#}");
    }
    let published = |o: &str| {
        let d = &r.summary.sensor_digests[o];
        let n = |k: &str| -> u64 {
            d.split_whitespace()
                .find_map(|w| w.strip_prefix(&format!("{k}=")))
                .unwrap()
                .parse()
                .unwrap()
        };
        (n("packets"), n("dropped"))
    };
    let (sent, dropped) = published("O1");
    assert!(dropped > 0, "{:?}", r.summary.sensor_digests);
    assert_eq!(v["observers"]["O1"]["regenerated"]["made"]["packets"], sent);
    // The recording holds the input, not one packet.
    let bytes = std::fs::read(&recording).unwrap();
    let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
    let topics: Vec<&str> = summary
        .channels
        .values()
        .map(|c| c.topic.as_str())
        .collect();
    assert!(topics.contains(&"/camera/O1/input"), "{topics:?}");
    assert!(
        !topics
            .iter()
            .any(|t| t.starts_with("/sensor/") && t.ends_with("/events")),
        "{topics:?}"
    );
    // Exported as a ROS 2 bag, the regenerated packets go in as the recorded ones would.
    let bag = out_dir_path("sensor-preset").join("bag");
    let export = export_ros2(&out_dir_path("sensor-preset"), &bag)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&export.stdout);
    assert!(
        export.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&export.stderr)
    );
    let made: u64 = v["observers"]
        .as_object()
        .unwrap()
        .values()
        .map(|o| o["regenerated"]["made"]["events"].as_u64().unwrap())
        .sum();
    assert!(
        text.contains(&format!("  {made} events, ")),
        "{made}: {text}"
    );
    assert!(text.contains("/O1/events"), "{text}");
    // Cut: compared where it covers the run, without a false mismatch (a lost render cannot be
    // regenerated past, and a cut file holds no account of the packets received).
    for k in [2, 3] {
        let cut = recording.with_file_name(format!("cut-{k}.mcap"));
        std::fs::write(&cut, &bytes[..bytes.len() * k / 4]).unwrap();
        let v = replay_json(&cut);
        assert_eq!(v["partial"], true, "cut {k}/4: {v:#}");
        assert_eq!(v["all_matched"], true, "cut {k}/4: {v:#}");
    }
    r.every_process_exited_cleanly();
    let sensor = r
        .summary
        .sensor
        .as_ref()
        .expect("summary.json records the sensor model");
    assert_eq!(sensor.preset.as_deref(), Some("v2e-default"));
    assert_eq!(sensor.terms, ["events.shot_noise_hz=0.01"]);
    assert_eq!(sensor.perturb["events.shot_noise_hz"], 0.01);
    assert_eq!(sensor.seed, 3);
    let text = std::fs::read_to_string(out_dir_path("sensor-preset").join("summary.json")).unwrap();
    assert!(text.contains("\"sensor\""), "{text}");
    // Each camera built its sensor from the preset (its log names the model it runs).
    let log = std::fs::read_to_string(out_dir_path("sensor-preset").join("logs/camera-O2.log"))
        .unwrap_or_default();
    assert!(log.contains("event sensor model"), "{log}");
}

#[test]
fn run_refuses_an_unknown_sensor_preset_and_other_groups_naming_them() {
    for (args, needles) in [
        (
            vec!["--sensor-preset", "v2e-loud"],
            vec!["v2e-loud", "v2e-default"],
        ),
        (
            vec!["--perturb", "rgb.read_noise_grey=4"],
            vec!["rgb.read_noise_grey"],
        ),
    ] {
        let out = waggle()
            .args(["run", "only-a", "--quiet"])
            .args(&args)
            .stdin(Stdio::null())
            .output()
            .unwrap();
        assert!(!out.status.success(), "{args:?} accepted");
        let err = String::from_utf8_lossy(&out.stderr);
        for n in needles {
            assert!(err.contains(n), "{args:?}: {err}");
        }
    }
}

#[test]
fn ctrl_c_stops_every_child_and_still_writes_the_summary() {
    let dir = out_dir("ctrl-c");
    let session = format!("ctrlc-{}", std::process::id());
    let mut child = spawn_background_run("nominal-3", &session, &dir);
    // Wait until every node runs, then a few seconds of mission.
    let start = Instant::now();
    while processes_of(&session).len() < 10 {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "nodes never started"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    // A second run on the same directory is refused while this one writes it.
    let second = waggle_with_nodes()
        .args(["run", "only-a", "--modality", "events", "--quiet", "--out"])
        .arg(&dir)
        .stdin(Stdio::null())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&second.stderr);
    assert!(!second.status.success(), "a second run on {dir:?} started");
    assert!(err.contains("in use by another waggle run"), "{err}");
    std::thread::sleep(Duration::from_secs(4));
    // Ctrl-C in a terminal: SIGINT to the whole foreground process group.
    let status = Command::new("kill")
        .args(["-INT", "--", &format!("-{}", child.id())])
        .status()
        .unwrap();
    assert!(status.success());
    let start = Instant::now();
    let code = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "waggle ignored Ctrl-C"
        );
        std::thread::sleep(Duration::from_millis(50));
    };
    assert!(
        !code.success(),
        "an interrupted run must not report success"
    );
    let left = processes_of(&session);
    assert!(left.is_empty(), "children left running: {left:#?}");
    let summary: RunSummary =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert!(summary.interrupted);
    assert!(!summary.mission.pass);
    assert!(
        dir.join("observers.json").exists(),
        "an interrupted run still writes observers.json"
    );
    assert!(summary.mission.mission_time_s > 0.0);
    // The recorder got SIGTERM and finished its file (summary and footer): audit reads it whole.
    let audit = waggle()
        .arg("audit")
        .arg(&dir)
        .arg("--json")
        .output()
        .unwrap();
    assert_ne!(audit.status.code(), Some(101), "audit panicked");
    let a: Value = serde_json::from_slice(&audit.stdout).unwrap_or_else(|e| {
        panic!(
            "audit printed no JSON ({e}): {}",
            String::from_utf8_lossy(&audit.stderr)
        )
    });
    assert_eq!(a["partial"], false, "{a:#}");
    assert_eq!(a["case"], "nominal-3");
    assert_eq!(a["pass"], false, "an interrupted mission has no report");
    assert!(
        a["packets_per_observer"]["O1"].as_u64().unwrap() > 0,
        "{a:#}"
    );
    assert!(a["mission_time_s"].as_f64().unwrap() > 0.0);
}

fn assert_nominal(r: &Run) {
    r.assert_pass();
    r.every_process_exited_cleanly();
    assert_eq!(r.messages(), [4, 4, 4]);
    assert_eq!(r.summary.mission.work_units, 6);
    // Round 1: O1 and O2 work at A, O3 at B; round 2: everyone at B.
    assert_eq!(r.services("O1"), ["A", "B"]);
    assert_eq!(r.services("O2"), ["A", "B"]);
    assert_eq!(r.services("O3"), ["B", "B"]);
    assert_eq!(r.summary.mission.contact_steps, 0);
    assert!(r.summary.missing_packets.is_empty());
    for o in ["O1", "O2", "O3"] {
        assert!(r.summary.home_error_m[o] < 0.05, "{o}");
    }
}

#[test]
#[ignore = "whole mission, ≈ 5 min: cargo test --release -p waggle-tests --test run -- --ignored"]
fn nominal_3_events_as_processes() {
    assert_nominal(&run("nominal-3", "events", "nominal-events", &[]));
}

#[test]
#[ignore = "whole mission, ≈ 5 min: cargo test --release -p waggle-tests --test run -- --ignored"]
fn nominal_3_rgb_as_processes() {
    assert_nominal(&run("nominal-3", "rgb", "nominal-rgb", &[]));
}

/// Eight event cameras as processes in the two-row formation: every observer releases every
/// frame (4 complete messages each), nobody is deaf, no contact, separation ≥ 0.35 m, and the
/// case's expected services. ≈ 7.5 min of wall on an idle 2-core machine (577 s of sim).
#[test]
#[ignore = "whole mission with 8 event cameras, ≈ 8 min: cargo test --release -p waggle-tests --test run -- --ignored"]
fn eight_observers_events_as_processes() {
    let r = run("eight-observers", "events", "eight-events", &[]);
    r.assert_pass();
    r.every_process_exited_cleanly();
    assert_eq!(r.messages(), [4; 8]);
    assert!(r.summary.mission.deaf_observers.is_empty());
    assert_eq!(r.summary.mission.contact_steps, 0);
    assert!(r.summary.mission.min_separation_m >= 0.35);
    assert!(
        r.summary.missing_packets.is_empty(),
        "{:?}",
        r.summary.missing_packets
    );
}

#[test]
#[ignore = "whole mission, ≈ 5 min: cargo test --release -p waggle-tests --test run -- --ignored"]
fn dropout_o2_kills_the_camera_and_o2_never_moves() {
    let r = run("dropout-o2", "events", "dropout", &[]);
    r.assert_pass();
    r.every_process_exited_cleanly();
    assert_eq!(r.messages(), [4, 0, 4]);
    assert_eq!(r.summary.mission.work_units, 4);
    assert!(r.services("O2").is_empty());
    assert!(r.summary.processes["camera-O2"].killed_by_fault);
    assert_eq!(r.summary.processes["camera-O2"].exit, "signal 9");
    assert!(r.summary.max_excursion_m["O2"] < 0.02);
    assert!(r.summary.max_excursion_m["O1"] > 1.0);
    assert!(r.observers["O2"].decisions.is_empty());
    // Every tick after the kill is missing for O2 only.
    let missing = &r.summary.missing_packets;
    assert_eq!(missing.keys().collect::<Vec<_>>(), ["O2"]);
    let ticks_after = (r.summary.mission.mission_time_s - 35.0) / 0.04;
    assert!(missing["O2"] as f64 > ticks_after - 10.0);
}

#[test]
#[ignore = "two whole missions, ≈ 10 min: cargo test --release -p waggle-tests --test run -- --ignored"]
fn two_runs_of_nominal_3_are_identical_even_behind_an_observer_acl() {
    let a = run("nominal-3", "events", "det-a", &[]);
    // The second run closes every observer's links to ground truth, commands, faults and the
    // other observers' keys with a Zenoh ACL (docs/DESIGN.md §2): nothing may change.
    let b = run("nominal-3", "events", "det-b", &["--observer-acl"]);
    assert_nominal(&a);
    assert_nominal(&b);
    // Tokens with their confirmation times, frames with every token stamp, decisions.
    assert_eq!(a.observers, b.observers);
    let (ma, mb) = (&a.summary.mission, &b.summary.mission);
    assert_eq!(ma.observers, mb.observers);
    assert_eq!(ma.work_units, mb.work_units);
    assert_eq!(ma.mission_time_s, mb.mission_time_s);
    assert_eq!(ma.end_reason, mb.end_reason);
    assert_eq!(ma.contact_steps, mb.contact_steps);
    assert_eq!(ma.min_separation_m, mb.min_separation_m);
    assert_eq!(a.summary.sensor_digests, b.summary.sensor_digests);
    assert_eq!(a.summary.home_error_m, b.summary.home_error_m);
    assert_eq!(a.summary.max_excursion_m, b.summary.max_excursion_m);
    assert_ne!(a.summary.session, b.summary.session);
}

/// The `dropped=` count of a camera's digest line.
fn dropped_of(digest: &str) -> u64 {
    digest
        .split_whitespace()
        .find_map(|f| f.strip_prefix("dropped="))
        .unwrap()
        .parse()
        .unwrap()
}

/// How many times the observer's log says a packet was missing for `why`.
fn missing_in_log(name: &str, observer: &str, why: &str) -> usize {
    let log =
        std::fs::read_to_string(out_dir_path(name).join(format!("logs/observer-{observer}.log")))
            .unwrap_or_default();
    log.lines()
        .filter(|l| l.contains("packet missing") && l.contains(why))
        .count()
}

/// A grace period no test waits out: if a verdict took it, the run would stall for minutes and
/// the log would say "grace period expired".
const NEVER_GRACE_MS: &str = "600000";

/// A throttled camera announces each packet it drops, so its observer judges exactly those
/// missing the moment the notice arrives, never by the wall clock: with a grace period no run
/// could wait out, a one-observer case cut to 6 s of sim time with a quarter of its packets
/// dropped ends in seconds, every missing packet is one the camera dropped, and the log names the
/// notice as the reason for each.
#[test]
fn a_throttled_camera_says_what_it_dropped_and_no_verdict_waits_on_the_clock() {
    let case = std::env::temp_dir().join(format!(
        "waggle-run-test-{}-throttle-short.toml",
        std::process::id()
    ));
    std::fs::write(
        &case,
        "name = \"throttle-short\"\nobservers = 1\nmodalities = [\"events\"]\n\
         offer_sites = [\"A\"]\ntime_limit_s = 6\n\n\
         [[faults]]\nobserver = \"O1\"\nkind = \"throttle\"\nat_s = 1\ndrop_per_mille = 250\n\n\
         [expected]\nmessages = [0]\nwork_units = 0\nservices = { O1 = [] }\n",
    )
    .unwrap();
    let started = Instant::now();
    let r = run(
        case.to_str().unwrap(),
        "events",
        "throttle-short",
        &["--grace-ms", NEVER_GRACE_MS],
    );
    r.assert_pass();
    assert!(
        started.elapsed() < Duration::from_secs(120),
        "{:?}",
        started.elapsed()
    );
    let dropped = dropped_of(&r.summary.sensor_digests["O1"]);
    // 5 s of 25 packets a second, a quarter of them dropped.
    assert!((15..=50).contains(&dropped), "{dropped}");
    assert_eq!(r.summary.missing_packets["O1"], dropped);
    assert_eq!(
        missing_in_log("throttle-short", "O1", "the camera dropped it") as u64,
        dropped
    );
    let _ = std::fs::remove_file(&case);
}

/// Two throttled runs of a whole case (≈ 3 s each), one also delaying every packet it sends: the same packets
/// go missing for the same reason (the camera's notice), and the observers' outputs are
/// byte-identical — a delay on one key changes when messages arrive, never what a tick holds.
#[test]
fn throttled_runs_with_and_without_delay_are_identical() {
    let a = run(
        "no-broadcast",
        "events",
        "throttle",
        &["--throttle", "O1@0:100:0", "--grace-ms", NEVER_GRACE_MS],
    );
    let b = run(
        "no-broadcast",
        "events",
        "throttle-delay",
        &["--throttle", "O1@0:100:4", "--grace-ms", NEVER_GRACE_MS],
    );
    for r in [&a, &b] {
        r.assert_pass();
        let dropped = dropped_of(&r.summary.sensor_digests["O1"]);
        assert!((15..=60).contains(&dropped), "{dropped}");
        let missing = &r.summary.missing_packets;
        assert_eq!(missing.keys().collect::<Vec<_>>(), ["O1"]);
        assert_eq!(missing["O1"], dropped);
    }
    for name in ["throttle", "throttle-delay"] {
        assert_eq!(
            missing_in_log(name, "O1", "the camera dropped it") as u64,
            a.summary.missing_packets["O1"],
            "{name}"
        );
    }
    assert_eq!(a.summary.sensor_digests, b.summary.sensor_digests);
    let bytes = |name: &str| std::fs::read(out_dir_path(name).join("observers.json")).unwrap();
    assert!(
        bytes("throttle") == bytes("throttle-delay"),
        "observers.json differs"
    );
}

/// Sched broadcasts recorded in `dir/session.mcap`: (round, offers' payloads) in order.
fn recorded_broadcasts(dir: &std::path::Path) -> Vec<(u32, Vec<String>)> {
    use recording::{Decoded, MessageKind, RAW_ENCODING, ReadError, decode, read_recording};
    let mut out = Vec::new();
    let outcome = read_recording::<ReadError>(&dir.join("session.mcap"), |m| {
        if let Some(MessageKind::BroadcastTick) = MessageKind::from_schema_name(m.schema)
            && m.message_encoding == RAW_ENCODING
            && let Decoded::BroadcastTick(t) = decode(MessageKind::BroadcastTick, m.data).unwrap()
            && let Some(b) = t.broadcast
        {
            let payloads = b.offers.iter().map(|o| o.to_bits()).collect();
            out.push((b.round, payloads));
        }
        Ok(())
    })
    .unwrap();
    assert!(outcome.complete, "{:?}", outcome.problem);
    out
}

#[test]
fn a_repeated_checked_broadcast_is_recorded_audited_and_replayed() {
    // only-a offers A alone, so nobody ever holds a message for both sites and decides: with
    // --max-broadcasts 2 the round flies A twice, and each observer's one message counts once.
    // With --frame-check crc3 every frame carries three check bits (23 tokens): replay releases
    // the same frames only if it reads the check from the recorded case.
    let r = run(
        "only-a",
        "events",
        "max-broadcasts",
        &["--max-broadcasts", "2", "--frame-check", "crc3"],
    );
    r.assert_pass();
    r.every_process_exited_cleanly();
    assert_eq!(r.messages(), [1, 1, 1]);
    for o in ["O1", "O2", "O3"] {
        assert_eq!(
            r.summary.mission.observers[o].payloads,
            ["011010", "011010"],
            "{o}"
        );
        for f in &r.observers[o].frames {
            assert_eq!(f.frame.token_stamps_ns.len(), 23, "{o}: {f:?}");
        }
    }
    let dir = out_dir_path("max-broadcasts");
    let case = std::fs::read_to_string(dir.join("case.toml")).unwrap();
    assert!(case.contains("frame_check = \"crc3\""), "{case}");
    let flown = recorded_broadcasts(&dir);
    let a = vec!["011010".to_string()];
    assert_eq!(flown, [(1, a.clone()), (1, a)]);
    let audit = waggle()
        .arg("audit")
        .arg(&dir)
        .arg("--json")
        .output()
        .unwrap();
    let v: Value = serde_json::from_slice(&audit.stdout).unwrap();
    assert!(audit.status.success() && v["pass"] == true, "{v:#}");
    let v = replay_json(&dir.join("session.mcap"));
    assert_eq!(v["all_matched"], true, "{v:#}");
    // Out of range, refused before anything starts, naming the option.
    for (option, value) in [("--max-broadcasts", "9"), ("--frame-check", "crc8")] {
        let bad = waggle()
            .args(["run", "only-a", option, value])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&bad.stderr);
        assert!(!bad.status.success() && stderr.contains(option), "{stderr}");
    }
}

/// Sim time after which memory must be flat: the first rounds (≈ 240 s each) fill every
/// process's caches, pools and the allocator's arenas.
const FIRST_ROUNDS_S: u64 = 600;

/// Each process's growth from the first sample at or after [`FIRST_ROUNDS_S`] to the last
/// sample every process was alive for: (name, kB then, kB last, growth %, kB per sim minute).
fn rss_growth(csv: &std::path::Path) -> Vec<(String, u64, u64, f64, f64)> {
    let (names, rows) = deploy::launch::rss::read(csv).unwrap();
    let base = rows
        .iter()
        .find(|(s, _)| *s >= FIRST_ROUNDS_S)
        .expect("a sample after the first rounds");
    let last = rows
        .iter()
        .rev()
        .find(|(_, kb)| kb.iter().all(Option::is_some))
        .expect("a sample with every process alive");
    let minutes = (last.0 - base.0) as f64 / 60.0;
    names
        .iter()
        .enumerate()
        .map(|(i, name)| {
            let (from, to) = (base.1[i].unwrap_or(0), last.1[i].unwrap_or(0));
            let grown = to as f64 - from as f64;
            let pct = 100.0 * grown / from.max(1) as f64;
            (name.clone(), from, to, pct, grown / minutes.max(1.0))
        })
        .collect()
}

/// The most a process may grow after the first rounds: 10 % of its size then, the target
/// every process but the recorder meets. The recorder keeps the MCAP chunk index its file's
/// summary needs (about 0.85 kB for each chunk, ≈ 1.4 chunks a sim second here), so it grows
/// with what it records; it is bounded in kB per sim minute at about twice what an hour
/// measured, 111 kB/min (docs/decisions/long-runs.md).
fn growth_limit(name: &str) -> GrowthLimit {
    match name {
        "recorder" => GrowthLimit::KbPerSimMinute(240.0),
        _ => GrowthLimit::Percent(10.0),
    }
}

#[derive(Debug, Clone, Copy)]
enum GrowthLimit {
    Percent(f64),
    KbPerSimMinute(f64),
}

/// long-hour as processes with event cameras: 16 rounds, more than an hour of sim time, every
/// process's memory sampled each sim minute. The outcome is the case's, and after the first
/// rounds no process grows by more than its [`growth_limit`].
#[test]
#[ignore = "an hour of sim time as processes, ≈ 9 min: deploy/test.sh --full"]
fn long_hour_memory_stays_flat_after_the_first_rounds() {
    let r = run("long-hour", "events", "long-hour", &["--rss-every-s", "60"]);
    let growth = rss_growth(&out_dir_path("long-hour").join("rss.csv"));
    for (name, from, to, pct, per_min) in &growth {
        println!(
            "{name}: {from} kB at {FIRST_ROUNDS_S} s → {to} kB ({pct:+.1} %, {per_min:+.1} kB/sim min)"
        );
    }
    r.assert_pass();
    r.every_process_exited_cleanly();
    assert!(
        r.summary.mission.mission_time_s >= 3600.0,
        "{}",
        r.summary.mission.mission_time_s
    );
    assert_eq!(growth.len(), 11, "{growth:?}");
    for (name, from, to, pct, per_min) in &growth {
        let within = match growth_limit(name) {
            GrowthLimit::Percent(limit) => *pct <= limit,
            GrowthLimit::KbPerSimMinute(limit) => *per_min <= limit,
        };
        assert!(
            within,
            "{name}: {from} → {to} kB ({pct:+.1} %, {per_min:+.1} kB/sim min), limit {:?}",
            growth_limit(name)
        );
    }
}
