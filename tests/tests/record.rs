//! Recordings: `recorder-node` under `waggle run`, `waggle replay` and `waggle audit`.
//!
//! Proves `waggle audit` fails a recording whose decisions violate provenance and says why, reads
//! truncated or corrupt recordings as partial (or refuses them clearly) instead of panicking,
//! reads what a recorder killed mid-session left on disk; and, for whole missions, that the
//! recording audits as the paper, opens usefully in Foxglove, and (events) replays every payload.
//!
//! ```text
//! cargo build --release --workspace --bins
//! cargo test --release -p waggle-tests --test record                # short tests (≈ 20 s)
//! cargo test --release -p waggle-tests --test record -- --ignored   # whole missions (≈ 7 min each)
//! ```

use std::collections::BTreeMap;
use std::io::Cursor;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use proto::frame::{FrameParser, frame_tokens};
use proto::{
    ClockTick, Decision, Departure, FrameEvent, Keys, MissionReport, ObserverId, Offer,
    SessionControl, SessionEvent, SessionTick, Site, SourceFrame, TICK_NS,
};
use recording::{RecorderOptions, SessionInfo, SessionWriter};
use serde_json::Value;
use waggle_tests::{spawn_background_run, waggle, waggle_with_nodes};

fn out_dir(name: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("waggle-record-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn text(o: &Output) -> String {
    format!(
        "status {:?}\nstdout:\n{}\nstderr:\n{}",
        o.status,
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// `waggle <cmd> PATH --json`: (exit success, parsed JSON or None, output).
fn json_of(cmd: &str, path: &Path) -> (bool, Option<Value>, Output) {
    let o = waggle()
        .args([cmd])
        .arg(path)
        .arg("--json")
        .output()
        .unwrap();
    assert_ne!(
        o.status.code(),
        Some(101),
        "waggle {cmd} panicked: {}",
        text(&o)
    );
    let v = serde_json::from_slice(&o.stdout).ok();
    (o.status.success(), v, o)
}

fn o(name: &str) -> ObserverId {
    ObserverId::new(name).unwrap()
}

fn frame(observer: &str, seq: u64, round: u32, bits: &str, final_null_ns: u64) -> FrameEvent {
    let payload = u8::from_str_radix(bits, 2).unwrap();
    let mut parser = FrameParser::new();
    let tokens = frame_tokens(payload);
    let mut released = None;
    for (i, t) in tokens.iter().enumerate() {
        let stamp = final_null_ns - (16 - i as u64) * 1_000_000_000;
        released = parser.push(*t, stamp).or(released);
    }
    FrameEvent {
        observer: o(observer),
        seq,
        round,
        frame: released.expect("a whole frame releases"),
    }
}

/// A small recording of the nominal-3 case: one observer's round-1 frames and decision (made
/// at `decided_ns`), the scheduler's report with its departure. Returns the file's bytes.
fn constructed(decided_ns: u64) -> Vec<u8> {
    let keys = Keys::new("constructed").unwrap();
    let info = SessionInfo {
        sensor_args: Vec::new(),
        events_from_input: false,
        session: "constructed".into(),
        observers: 3,
        case_name: Some("nominal-3".into()),
        case_toml: Some(include_str!("../../deploy/cases/nominal-3.toml").into()),
        modality: Some("events".into()),
    };
    let options = RecorderOptions {
        chunk_bytes: 2048,
        ..RecorderOptions::default()
    };
    let mut w = SessionWriter::new(Cursor::new(Vec::new()), &info, options).unwrap();
    let o1 = o("O1");
    let a = frame("O1", 0, 1, "011010", 40_000_000_000);
    let b = frame("O1", 1, 1, "100111", 80_000_000_000);
    for k in 0..=2500u64 {
        w.record(&keys.clock(), &proto::encode(&ClockTick::at(k).unwrap()))
            .unwrap();
        let mut controls = Vec::new();
        if k == 0 {
            controls.push(SessionControl {
                tick: 0,
                stamp_ns: 0,
                event: SessionEvent::WindowOpen { round: 1 },
            });
        }
        w.record(
            &keys.sched_session(),
            &proto::encode(&SessionTick { tick: k, controls }),
        )
        .unwrap();
        if k * TICK_NS == 40_000_000_000 {
            w.record(&keys.observer_frames(&o1), &proto::encode(&a))
                .unwrap();
        }
        if k * TICK_NS == 80_000_000_000 {
            w.record(&keys.observer_frames(&o1), &proto::encode(&b))
                .unwrap();
        }
    }
    let source = |f: &FrameEvent| SourceFrame {
        observer: o1.clone(),
        frame_seq: f.seq,
        offer: Offer::from_payload(f.frame.payload).unwrap(),
        final_null_ns: f.frame.final_null_ns(),
    };
    let decision = Decision {
        observer: o1.clone(),
        round: 1,
        decided_ns,
        assignment: Some(Site::A),
        sources: vec![source(&a), source(&b)],
        allocation: BTreeMap::from([(o1.clone(), Some(Site::A))]),
    };
    w.record(&keys.observer_decision(&o1), &proto::encode(&decision))
        .unwrap();
    let report = MissionReport {
        tick: 2500,
        end_ns: 2500 * TICK_NS,
        end_reason: proto::EndReason::RoundsComplete,
        work_units: 1,
        services: BTreeMap::from([(o1.clone(), vec![(1, Site::A)])]),
        departures: vec![Departure {
            observer: o1.clone(),
            round: 1,
            site: Site::A,
            t_ns: 81_000_000_000,
        }],
        rejected_decisions: 0,
    };
    w.record(&keys.sched_report(), &proto::encode(&report))
        .unwrap();
    w.finish(BTreeMap::new()).unwrap().into_inner()
}

#[test]
fn audit_of_a_recording_with_violated_provenance_fails_with_the_reason() {
    let dir = out_dir("provenance");
    // Decided at 60 s, before B's final NULL at 80 s: the sources do not support it.
    let bad = dir.join("bad.mcap");
    std::fs::write(&bad, constructed(60_000_000_000)).unwrap();
    let (ok, v, out) = json_of("audit", &bad);
    let v = v.unwrap_or_else(|| panic!("no JSON: {}", text(&out)));
    assert!(!ok, "a violated provenance must fail: {}", text(&out));
    assert_eq!(v["pass"], false);
    assert_eq!(v["partial"], false);
    assert_eq!(v["case"], "nominal-3");
    let violations = v["provenance_violations"].as_array().unwrap();
    assert_eq!(violations.len(), 1, "{v:#}");
    let reason = violations[0].as_str().unwrap();
    assert!(
        reason.contains("O1 decided at 60000000000 ns, before the final NULL of B"),
        "{reason}"
    );
    assert!(
        v["reasons"]
            .as_array()
            .unwrap()
            .iter()
            .any(|r| r.as_str().unwrap().starts_with("provenance: O1 decided")),
        "{v:#}"
    );
    assert_eq!(v["assignments_audited"], 1);
    assert_eq!(v["messages"]["O1"], 2);
    assert_eq!(v["work_units_by_observer"]["O1"]["A"], 1);
    assert_eq!(v["timing"]["latest_final_reception_s"], 80.0);
    assert_eq!(v["timing"]["latest_reception_to_completion_s"], 20.0);
    // The same recording with the decision after both final NULLs has no violation (it still
    // fails the nominal case's expected counts).
    let good = dir.join("good.mcap");
    std::fs::write(&good, constructed(80_000_000_000)).unwrap();
    let (_, v, out) = json_of("audit", &good);
    let v = v.unwrap_or_else(|| panic!("no JSON: {}", text(&out)));
    assert_eq!(v["provenance_violations"], serde_json::json!([]), "{v:#}");
    assert_eq!(v["assignments_audited"], 1);
    assert!(
        v["reasons"]
            .as_array()
            .unwrap()
            .iter()
            .any(|r| r.as_str().unwrap().contains("complete messages [2, 0, 0]")),
        "{v:#}"
    );
}

#[test]
fn truncated_or_corrupt_recordings_give_partial_results_or_clear_errors() {
    let dir = out_dir("truncated");
    let bytes = constructed(80_000_000_000);
    let mut partial_seen = 0;
    for cut in [
        0,
        5,
        60,
        bytes.len() / 10,
        bytes.len() / 3,
        bytes.len() / 2,
        bytes.len() * 9 / 10,
        bytes.len() - 10,
    ] {
        let path = dir.join(format!("cut-{cut}.mcap"));
        std::fs::write(&path, &bytes[..cut]).unwrap();
        let (ok, v, out) = json_of("audit", &path);
        assert!(!ok, "cut at {cut} must not pass: {}", text(&out));
        match v {
            Some(v) => {
                assert_eq!(v["partial"], true, "cut {cut}: {v:#}");
                assert!(
                    v["reasons"][0]
                        .as_str()
                        .unwrap()
                        .starts_with("partial recording"),
                    "{v:#}"
                );
                partial_seen += 1;
            }
            None => {
                let err = String::from_utf8_lossy(&out.stderr);
                assert!(err.contains("not an MCAP file"), "cut {cut}: {err}");
            }
        }
        // Replay of a cut events recording: a clear error or a (partial) result, no panic.
        let _ = json_of("replay", &path);
    }
    assert!(partial_seen >= 4, "most cuts read as partial");
    // Damage at seven places: at least one lands inside a chunk (whose CRC then fails).
    let mut bad = bytes.clone();
    for k in 1..8 {
        let at = bad.len() * k / 8;
        for b in &mut bad[at..at + 32] {
            *b = !*b;
        }
    }
    let path = dir.join("corrupt.mcap");
    std::fs::write(&path, &bad).unwrap();
    let (ok, v, out) = json_of("audit", &path);
    assert!(!ok);
    assert_eq!(v.unwrap()["partial"], true, "{}", text(&out));
    let missing = dir.join("nothing-here");
    let (ok, _, out) = json_of("audit", &missing);
    assert!(!ok && String::from_utf8_lossy(&out.stderr).contains("nothing-here"));
}

/// Pids of running processes whose command line names `needle` and `session`.
fn pids_of(session: &str, needle: &str) -> Vec<u32> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir("/proc").unwrap().flatten() {
        let Ok(pid) = entry.file_name().to_string_lossy().parse::<u32>() else {
            continue;
        };
        let cmdline = std::fs::read(entry.path().join("cmdline")).unwrap_or_default();
        let text = String::from_utf8_lossy(&cmdline).replace('\0', " ");
        if text.contains(session) && text.contains(needle) && !text.contains("cargo") {
            out.push(pid);
        }
    }
    out
}

#[test]
fn a_recorder_killed_mid_session_leaves_a_recording_audit_reads_as_partial() {
    let dir = out_dir("killed");
    let session = format!("rec-kill-{}", std::process::id());
    // A mission with broadcasts: with damage rendering `no-broadcast` ends in about two seconds
    // of wall time, before the recorder could be killed mid-session.
    let mut child = spawn_background_run("nominal-3", &session, &dir);
    let mcap = dir.join("session.mcap");
    // Wait for a few seconds of mission on disk, then SIGKILL the recorder.
    let start = Instant::now();
    let recorder = loop {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "the recorder never started"
        );
        let pids = pids_of(&session, "recorder-node");
        if let [pid] = pids[..]
            && std::fs::metadata(&mcap).is_ok_and(|m| m.len() > 64 * 1024)
        {
            break pid;
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    std::thread::sleep(Duration::from_secs(2));
    assert!(
        Command::new("kill")
            .args(["-KILL", &recorder.to_string()])
            .status()
            .unwrap()
            .success()
    );
    let status = child.wait().unwrap();
    assert!(!status.success(), "a run whose recorder died must fail");
    let (ok, v, out) = json_of("audit", &dir);
    assert!(!ok);
    let v = v.unwrap_or_else(|| panic!("no JSON: {}", text(&out)));
    assert_eq!(v["partial"], true, "{v:#}");
    assert_eq!(v["case"], "nominal-3");
    assert_eq!(v["pass"], false);
    let packets = v["packets_per_observer"]["O1"].as_u64().unwrap();
    assert!(
        packets > 10,
        "the chunks before the kill are readable: {v:#}"
    );
    assert!(v["mission_time_s"].as_f64().unwrap() > 0.0);
}

/// The recording opens usefully in Foxglove: images per observer, poses and logs, each on a
/// channel with a Foxglove schema; every raw topic carries its Waggle schema.
fn assert_foxglove_views(path: &Path, modality: &str) {
    let mut seen: BTreeMap<(String, String), u64> = BTreeMap::new();
    let out = recording::read_recording::<recording::ReadError>(path, |m| {
        *seen
            .entry((m.topic.to_string(), m.schema.to_string()))
            .or_default() += 1;
        Ok(())
    })
    .unwrap();
    assert!(out.complete, "{:?}", out.problem);
    for o in ["O1", "O2", "O3"] {
        let image = (
            format!("/view/{o}/{modality}"),
            "foxglove.RawImage".to_string(),
        );
        assert!(
            seen.get(&image).is_some_and(|n| *n > 100),
            "{image:?}: {seen:?}"
        );
        let raw = (
            format!("/sensor/{o}/{modality}"),
            format!(
                "waggle.{}",
                if modality == "rgb" {
                    "RgbUpdate"
                } else {
                    "EventPacket"
                }
            ),
        );
        assert!(seen.contains_key(&raw), "{raw:?}");
    }
    for view in [
        ("/view/tf", "foxglove.FrameTransforms"),
        ("/view/log", "foxglove.Log"),
        ("/view/scene", "foxglove.SceneUpdate"),
    ] {
        assert!(
            seen.contains_key(&(view.0.to_string(), view.1.to_string())),
            "{view:?}"
        );
    }
    assert!(
        seen.keys()
            .any(|(t, s)| t == "/sched/report" && s == "waggle.MissionReport")
    );
}

/// `waggle run CASE --modality M --out DIR`, asserting it passed.
fn run_case(case: &str, modality: &str, dir: &Path) {
    let o = waggle_with_nodes()
        .args(["run", case, "--modality", modality, "--quiet", "--out"])
        .arg(dir)
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
}

fn assert_nominal_audit(dir: &Path, modality: &str) -> Value {
    let (ok, v, out) = json_of("audit", dir);
    let v = v.unwrap_or_else(|| panic!("no JSON: {}", text(&out)));
    assert!(ok, "{v:#}");
    assert_eq!(v["pass"], true);
    assert_eq!(v["partial"], false);
    assert_eq!(v["modality"], modality);
    assert_eq!(
        v["messages"],
        serde_json::json!({"O1": 4, "O2": 4, "O3": 4})
    );
    assert_eq!(v["work_units"], 6);
    assert_eq!(v["work_units_by_site"], serde_json::json!({"A": 2, "B": 4}));
    assert_eq!(v["contact_steps"], 0);
    assert_eq!(v["provenance_violations"], serde_json::json!([]));
    assert_eq!(v["assignments_audited"], 6);
    for o in ["O1", "O2", "O3"] {
        let intervals = v["timing"]["offer_to_final_null_s"][o].as_array().unwrap();
        assert_eq!(intervals.len(), 4, "{o}");
        for i in intervals {
            let s = i.as_f64().unwrap();
            assert!((80.0..110.0).contains(&s), "{o}: offer to final NULL {s} s");
        }
    }
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(v["mission_time_s"], summary["mission_time_s"]);
    assert_eq!(v["min_separation_m"], summary["min_separation_m"]);
    v
}

/// `waggle replay` reproduces every live decode of `dir`'s recording: `per_observer` payloads
/// for each of `observers`.
fn assert_replay_reproduces(dir: &Path, observers: &[&str], per_observer: u64) -> Value {
    let (ok, r, out) = json_of("replay", &dir.join("session.mcap"));
    let r = r.unwrap_or_else(|| panic!("no JSON: {}", text(&out)));
    assert!(ok, "{r:#}");
    assert_eq!(r["partial"], false, "{r:#}");
    for o in observers {
        let x = &r["observers"][o];
        assert_eq!(x["payloads_live"], per_observer, "{o}: {x:#}");
        assert_eq!(x["payloads_matched"], per_observer, "{o}: {x:#}");
        assert_eq!(x["mismatches"], serde_json::json!([]), "{o}");
        assert_eq!(x["tokens_identical"], true, "{o}");
        assert_eq!(x["decisions_identical"], true, "{o}");
        assert_eq!(x["input_disagreements"], serde_json::json!([]), "{o}");
    }
    r
}

#[test]
#[ignore = "whole mission, ≈ 7 min: cargo test --release -p waggle-tests --test record -- --ignored"]
fn nominal_3_events_recording_replays_all_12_payloads_and_audits_as_the_paper() {
    let dir = out_dir("nominal-events");
    run_case("nominal-3", "events", &dir);
    let v = assert_nominal_audit(&dir, "events");
    for o in ["O1", "O2", "O3"] {
        assert!(
            v["events_per_observer"][o].as_u64().unwrap() > 100_000,
            "{o}"
        );
        assert!(
            v["packets_per_observer"][o].as_u64().unwrap() > 10_000,
            "{o}"
        );
    }
    let size = std::fs::metadata(dir.join("session.mcap")).unwrap().len();
    assert!(size < 1 << 30, "recording of {size} bytes exceeds 1 GB");
    assert_foxglove_views(&dir.join("session.mcap"), "events");
    let r = assert_replay_reproduces(&dir, &["O1", "O2", "O3"], 4);
    assert_eq!(r["modality"], "events");
}

#[test]
#[ignore = "whole mission, ≈ 6 min: cargo test --release -p waggle-tests --test record -- --ignored"]
fn nominal_3_rgb_recording_holds_every_frame_and_replays_every_decode() {
    let dir = out_dir("nominal-rgb");
    run_case("nominal-3", "rgb", &dir);
    let v = assert_nominal_audit(&dir, "rgb");
    // Every frame of every camera (one per tick) is in the recording, within 1 GB.
    let summary: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    for o in ["O1", "O2", "O3"] {
        let digest = summary["sensor_digests"][o].as_str().unwrap();
        let published: u64 = digest
            .split_whitespace()
            .find_map(|w| w.strip_prefix("packets="))
            .unwrap()
            .parse()
            .unwrap();
        assert_eq!(
            v["packets_per_observer"][o].as_u64(),
            Some(published),
            "{o}"
        );
    }
    let size = std::fs::metadata(dir.join("session.mcap")).unwrap().len();
    assert!(size < 1 << 30, "recording of {size} bytes exceeds 1 GB");
    assert_foxglove_views(&dir.join("session.mcap"), "rgb");
    let r = assert_replay_reproduces(&dir, &["O1", "O2", "O3"], 4);
    assert_eq!(r["modality"], "rgb");
}

#[test]
fn replay_of_a_cut_or_damaged_recording_compares_what_it_covers_without_false_mismatch() {
    let dir = out_dir("replay-cut");
    run_case("only-a", "events", &dir);
    assert_replay_reproduces(&dir, &["O1", "O2", "O3"], 1);
    let bytes = std::fs::read(dir.join("session.mcap")).unwrap();
    // Cuts everywhere, dense near the end where the observers' last packets are.
    let mut cuts: Vec<usize> = (1..12).map(|k| bytes.len() * k / 12).collect();
    cuts.extend((1..12).map(|k| bytes.len() - k * 4096));
    let mut partial_ok = 0;
    for cut in cuts {
        let path = dir.join(format!("cut-{cut}.mcap"));
        std::fs::write(&path, &bytes[..cut]).unwrap();
        let (ok, r, out) = json_of("replay", &path);
        match r {
            Some(r) => {
                assert!(ok, "cut at {cut}: a false mismatch\n{r:#}");
                assert_eq!(r["partial"], true, "cut at {cut}");
                assert_eq!(r["all_matched"], true, "cut at {cut}");
                partial_ok += 1;
            }
            // Before any packet: a clear error, not a mismatch.
            None => assert!(
                String::from_utf8_lossy(&out.stderr).contains("nothing to replay"),
                "cut at {cut}: {}",
                text(&out)
            ),
        }
        let _ = std::fs::remove_file(&path);
    }
    assert!(partial_ok >= 18, "{partial_ok} cuts replayed");
    // A damaged stretch in the middle of the chunk that holds the file's middle: compared up to
    // the damage, the rest reported. (Chunk boundaries follow the recorder's wall-clock flushes,
    // so the file's middle byte alone may fall on the message indexes between chunks, which the
    // reader does not need: the damage is placed inside a chunk, where it must be detected.)
    let mut bad = bytes.clone();
    let summary = mcap::Summary::read(&bytes)
        .expect("the recording's summary reads")
        .expect("the recording has a summary");
    let half = (bytes.len() / 2) as u64;
    let chunk = summary
        .chunk_indexes
        .iter()
        .find(|c| (c.chunk_start_offset..c.chunk_start_offset + c.chunk_length).contains(&half))
        .or_else(|| summary.chunk_indexes.iter().max_by_key(|c| c.chunk_length))
        .expect("the recording has chunks");
    let mid = usize::try_from(chunk.chunk_start_offset + chunk.chunk_length / 2).unwrap();
    for b in &mut bad[mid..mid + 64] {
        *b = !*b;
    }
    let path = dir.join("damaged.mcap");
    std::fs::write(&path, &bad).unwrap();
    let (ok, r, out) = json_of("replay", &path);
    let r = r.unwrap_or_else(|| panic!("no JSON: {}", text(&out)));
    assert!(ok, "{r:#}");
    assert_eq!(r["partial"], true);
    let (_, a, out) = json_of("audit", &path);
    let a = a.unwrap_or_else(|| panic!("no JSON: {}", text(&out)));
    assert_eq!(a["partial"], true);
    let why = a["partial_reason"].as_str().unwrap();
    assert!(
        why.contains("bytes ") && why.contains("resumed at the next intact chunk"),
        "{why}"
    );
    // Resynchronised: the audit still counts packets from after the damage.
    assert!(
        a["packets_per_observer"]["O1"].as_u64().unwrap() > 2_500,
        "{a:#}"
    );
}
