//! `waggle export ros2`: a run's recording as a ROS 2 bag, read back by independent readers.
//!
//! Each test runs a case as processes (`waggle run`; in the default suite `only-a` cut to its
//! first 16 s of sim time, ≈ 5–10 s of wall time per modality, which already holds every camera's
//! events or images, `/tf` and the first tokens), exports its recording and hands the bag to
//! `tools/ros2/check_bag.py` in the venv `deploy/setup.sh` makes (`tests/js/.venv`, pinned PyPI
//! `rosbags`, `mcap-ros2-support` and `evt3`; made here by running that script when they are
//! missing). The report must show every message read by both readers, identically, standard
//! types identical to ROS 2 Jazzy's with matching type hashes, and each camera's EVT 3.0
//! payloads decoding — by the independent `evt3` decoder — to exactly the recorded events at
//! microsecond resolution. Exporting the same run twice gives the same bytes; a damaged
//! recording is refused with the file and byte range named, and leaves no bag. The RGB bags'
//! O1 images, published live by a camera driver (`tools/ros2/publish_events.py`), decode with
//! `waggle observe` as `waggle decode` decodes the bag.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{Mutex, OnceLock};

use recording::{Decoded, MessageKind, RAW_ENCODING, ReadError, decode, read_recording};
use serde_json::Value;
use waggle_tests::{
    RosCameraDriver, export_ros2, succeed, waggle, waggle_with_nodes, workspace_root,
};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("waggle-ros2-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `waggle run CASE --modality MODALITY` (one run at a time: each keeps both cores busy) into a
/// scratch directory named by `label`.
fn run_case(case: &str, label: &str, modality: &str) -> PathBuf {
    static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());
    let _turn = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir = scratch(&format!("{label}-{modality}")).join("run");
    succeed(
        waggle_with_nodes()
            .args(["run", case, "--modality", modality, "--quiet", "--out"])
            .arg(&dir)
            .stdin(Stdio::null()),
        &format!("waggle run {case} --modality {modality}"),
    );
    dir
}

/// Sim time of the default suite's runs: long enough for the performer to move (events, changed
/// images) and for each observer to confirm its first token.
const SHORT_RUN_S: u64 = 16;

/// `only-a` (three observers, only site A offered) cut to its first [`SHORT_RUN_S`] of sim time.
fn short_case() -> String {
    format!(
        "name = \"only-a-short\"\nobservers = 3\nmodalities = [\"rgb\", \"events\"]\n\
         offer_sites = [\"A\"]\ntime_limit_s = {SHORT_RUN_S}\n\n[expected]\n\
         messages = [0, 0, 0]\nwork_units = 0\nservices = {{ O1 = [], O2 = [], O3 = [] }}\n"
    )
}

/// The short `only-a` run of `modality`, run once for every test that needs it.
fn only_a(modality: &'static str) -> &'static Path {
    static EVENTS: OnceLock<PathBuf> = OnceLock::new();
    static RGB: OnceLock<PathBuf> = OnceLock::new();
    let cell = if modality == "events" { &EVENTS } else { &RGB };
    cell.get_or_init(|| {
        let case = scratch(&format!("case-{modality}")).join("only-a-short.toml");
        std::fs::write(&case, short_case()).unwrap();
        run_case(case.to_str().unwrap(), "only-a-short", modality)
    })
}

/// `waggle export ros2 RUN --out BAG ARGS…`.
fn export(run: &Path, bag: &Path, args: &[&str]) -> String {
    let out = succeed(export_ros2(run, bag).args(args), "waggle export ros2");
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The venv's Python with the independent readers, made by `deploy/setup.sh` when missing.
fn python() -> PathBuf {
    let python = workspace_root().join("tests/js/.venv/bin/python");
    let ready = || {
        Command::new(&python)
            .args(["-c", "import rosbags, mcap_ros2, evt3, numpy"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    };
    static SETUP: OnceLock<()> = OnceLock::new();
    SETUP.get_or_init(|| {
        if !ready() {
            succeed(
                Command::new("bash").arg(workspace_root().join("deploy/setup.sh")),
                "bash deploy/setup.sh (the Python readers in tests/js/.venv)",
            );
        }
    });
    assert!(
        ready(),
        "tests/js/.venv lacks rosbags / mcap-ros2-support / evt3"
    );
    python
}

/// `tools/ros2/check_bag.py BAG`'s JSON report.
fn check(bag: &Path) -> Value {
    let out = succeed(
        Command::new(python())
            .arg(workspace_root().join("tools/ros2/check_bag.py"))
            .arg(bag),
        "tools/ros2/check_bag.py",
    );
    serde_json::from_slice(&out.stdout).expect("check_bag.py prints JSON")
}

/// What the recording holds, per bag topic: message counts, and per camera the events' count,
/// checksum (as check_bag.py computes it, at µs) and last time.
#[derive(Debug, Default)]
struct Recorded {
    counts: BTreeMap<String, u64>,
    /// Each observer's confirmed tokens, in order.
    tokens: BTreeMap<String, Vec<String>>,
    events: BTreeMap<String, (u64, u64, Option<u64>)>,
}

fn recorded(run: &Path) -> Recorded {
    let mut r = Recorded::default();
    let mut bump = |topic: String| *r.counts.entry(topic).or_insert(0) += 1;
    let mut events: BTreeMap<String, (u64, u64, Option<u64>)> = BTreeMap::new();
    let mut tokens: BTreeMap<String, Vec<String>> = BTreeMap::new();
    let outcome = read_recording::<ReadError>(&run.join("session.mcap"), |m| {
        let Some(kind) = MessageKind::from_schema_name(m.schema) else {
            return Ok(());
        };
        if m.message_encoding != RAW_ENCODING {
            return Ok(());
        }
        let observer = recording::topics::topic_observer(m.topic)
            .unwrap_or("?")
            .to_string();
        match decode(kind, m.data).expect("a recorded message decodes") {
            Decoded::SimState(_) => bump("/tf".into()),
            Decoded::EventPacket(p) => {
                bump(format!("/{observer}/events"));
                bump(format!("/{observer}/camera/camera_info"));
                let (n, sum, last) = events.entry(format!("/{observer}/events")).or_default();
                for i in 0..p.len() {
                    let t_us = p.t_ns(i) / 1000;
                    let v = t_us
                        .wrapping_mul(1_000_003)
                        .wrapping_add(u64::from(p.xs[i]) * 1009)
                        .wrapping_add(u64::from(p.ys[i]) * 17)
                        .wrapping_add(u64::from(p.polarity(i) == proto::Polarity::On));
                    *n += 1;
                    *sum = sum.wrapping_add(v.wrapping_mul(*n));
                    *last = Some(t_us);
                }
            }
            Decoded::RgbUpdate(_) | Decoded::RgbFrame(_) => {
                bump(format!("/{observer}/camera/image"));
                bump(format!("/{observer}/camera/camera_info"));
            }
            Decoded::TokenEvent(t) => {
                bump(format!("/{}/tokens", t.observer));
                tokens
                    .entry(t.observer.to_string())
                    .or_default()
                    .push(format!("{:?}", t.token).to_uppercase());
            }
            Decoded::FrameEvent(f) => bump(format!("/{}/frames", f.observer)),
            Decoded::Decision(d) => bump(format!("/{}/decision", d.observer)),
            Decoded::Fault(f) => bump(format!("/{}/fault", f.observer)),
            Decoded::BroadcastTick(t) if t.broadcast.is_some() => {
                bump("/performer/broadcast".into());
            }
            _ => {}
        }
        Ok(())
    })
    .unwrap();
    assert!(outcome.complete, "{:?}", outcome.problem);
    r.events = events;
    r.tokens = tokens;
    r
}

/// `waggle decode --events|--rgb BAG [--topic TOPIC] --observer O1`: O1's camera in the bag (or
/// PNG directory) through O1's receiver, from O1's place in the formation; the decoded tokens'
/// names.
fn decode_bag(input: &str, bag: &Path, topic: &str) -> Vec<String> {
    decode_bag_json(input, bag, topic)["decoded"]["tokens"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["token"].as_str().unwrap().to_owned())
        .collect()
}

/// `waggle decode INPUT BAG --topic TOPIC --observer O1 --json`.
fn decode_bag_json(input: &str, bag: &Path, topic: &str) -> Value {
    let out = succeed(
        waggle().args(["decode", input]).arg(bag).args([
            "--topic",
            topic,
            "--observer",
            "O1",
            "--json",
        ]),
        &format!("waggle decode {input} {}", bag.display()),
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// The bag's O1 images published live by a camera driver (three malformed messages among
/// them) and decoded by `waggle observe --kind KIND`, as `waggle decode` decodes the bag.
fn assert_observes_as_decoded(bag: &Path, topic: &str, kind: &str) {
    const DOMAIN: u32 = 23;
    let dir = bag.with_extension("live");
    std::fs::create_dir_all(&dir).unwrap();
    let driver = RosCameraDriver::start(
        &dir,
        DOMAIN,
        "/camera/image",
        bag,
        &["--bag-topic", topic, "--junk"],
    );
    let out = succeed(
        waggle()
            .args(["observe", "--topic", "/camera/image", "--kind", kind])
            .args(["--ros2-domain", &DOMAIN.to_string(), "--ros2-router"])
            .arg(&driver.endpoint)
            .args(["--observer", "O1", "--idle-s", "60", "--json"]),
        &format!("waggle observe --kind {kind}"),
    );
    let driven = driver.finish(std::time::Duration::from_secs(120));
    let observed: Value = serde_json::from_slice(&out.stdout).unwrap();
    let decoded = decode_bag_json("--rgb", bag, topic);
    assert_eq!(observed["ended"], "publishers left", "{observed}");
    assert_eq!(observed["refused"], 3, "{observed}");
    assert_eq!(
        observed["messages"].as_u64(),
        driven["messages"].as_u64().map(|n| n + 3),
        "{observed}"
    );
    assert_eq!(observed["packets"], decoded["packets"], "{observed}");
    assert_eq!(observed["decoded"], decoded["decoded"], "{kind}");
    assert!(
        !decoded["decoded"]["tokens"].as_array().unwrap().is_empty(),
        "{decoded}"
    );
}

/// The bag's O1 camera, decoded offline, gives the tokens O1 confirmed live.
fn assert_o1_decodes_as_live(input: &str, bag: &Path, topic: &str, rec: &Recorded) {
    let live = &rec.tokens["O1"];
    assert!(!live.is_empty(), "O1 confirmed no token live");
    let decoded = decode_bag(input, bag, topic);
    // The run stops mid-gesture; offline, the tail of silence may confirm one more token.
    assert!(
        decoded.len() >= live.len() && decoded[..live.len()] == live[..],
        "decoded {decoded:?}, live {live:?}"
    );
}

/// Every check of one exported bag against its recording; `image_topic` names where images go.
fn assert_bag_matches(bag: &Path, rec: &Recorded, image_topic: &str) -> Value {
    let report = check(bag);
    assert_eq!(report["profile"], "ros2");
    assert_eq!(report["disagreements"], Value::Array(vec![]), "{report}");
    let rosbags = report["rosbags"].as_object().unwrap();
    assert_eq!(rosbags, report["mcap_ros2"].as_object().unwrap());
    assert_eq!(rosbags, report["metadata"]["topics"].as_object().unwrap());
    let total: u64 = rosbags.values().map(|v| v.as_u64().unwrap()).sum();
    assert_eq!(report["metadata"]["message_count"], total);
    for (ty, t) in report["types"].as_object().unwrap() {
        assert_eq!(t["hash_ok"], true, "{ty}: {t}");
        assert_eq!(t["fields_match_jazzy"], true, "{ty}: {t}");
        assert_eq!(t["serialization"], "cdr", "{ty}");
    }
    // Every recorded message of an exported kind is in the bag, once.
    for (topic, &n) in &rec.counts {
        let topic = topic.replace("/camera/image", image_topic);
        assert_eq!(rosbags[&topic], n, "{topic}");
    }
    assert_eq!(rosbags["/tf_static"], 1);
    assert_eq!(rosbags.len(), rec.counts.len() + 1, "{rosbags:?}");
    // The independent EVT 3.0 decoder finds exactly the recorded events, at microseconds.
    let events = report["events"].as_object().unwrap();
    assert_eq!(events.len(), rec.events.len());
    for (topic, &(n, sum, last)) in &rec.events {
        let e = &events[topic];
        assert_eq!(e["problems"], Value::Array(vec![]), "{topic}: {e}");
        assert_eq!(e["events"], n, "{topic}");
        assert_eq!(e["checksum"], sum, "{topic}");
        assert_eq!(e["last_t_us"].as_u64(), last, "{topic}");
    }
    report
}

#[test]
fn only_a_events_exports_a_bag_both_readers_read_with_the_recorded_events() {
    let run = only_a("events");
    let dir = scratch("events-bags");
    let t0 = std::time::Instant::now();
    let stdout = export(run, &dir.join("1/bag"), &[]);
    eprintln!("export: {:.2} s\n{stdout}", t0.elapsed().as_secs_f64());
    let rec = recorded(run);
    assert!(
        rec.events.values().all(|e| e.0 > 100_000),
        "{:?}",
        rec.events
    );
    let report = assert_bag_matches(&dir.join("1/bag"), &rec, "");
    assert_eq!(report["events"].as_object().unwrap().len(), 3);
    assert_o1_decodes_as_live("--events", &dir.join("1/bag"), "/O1/events", &rec);
    // The run is long enough to hold Waggle's own messages too, and no longer than asked.
    assert!(
        rec.counts.keys().filter(|t| t.ends_with("/tokens")).count() == 3,
        "{:?}",
        rec.counts
    );
    for (topic, &(_, _, last)) in &rec.events {
        assert!(
            last.is_some_and(|t| t <= SHORT_RUN_S * 1_000_000),
            "{topic}"
        );
    }

    // Deterministic: the same run exported again (to a bag of the same name, which the MCAP's
    // rosbag2 metadata names) gives the same bytes.
    export(run, &dir.join("2/bag"), &[]);
    for file in ["bag/bag_0.mcap", "bag/metadata.yaml"] {
        let (a, b) = (dir.join("1").join(file), dir.join("2").join(file));
        let (a_bytes, b_bytes) = (std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
        assert!(
            a_bytes == b_bytes,
            "{} and {} differ",
            a.display(),
            b.display()
        );
    }
    let yaml = std::fs::read_to_string(dir.join("1/bag/metadata.yaml")).unwrap();
    assert!(yaml.starts_with("rosbag2_bagfile_information:\n  version: 9\n"));
    assert!(yaml.ends_with("  custom_data: ~\n  ros_distro: jazzy"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn only_a_rgb_exports_png_images_and_raw_images_on_request() {
    let run = only_a("rgb");
    let dir = scratch("rgb-bags");
    let rec = recorded(run);
    let t0 = std::time::Instant::now();
    let stdout = export(run, &dir.join("png"), &[]);
    eprintln!("export: {:.2} s\n{stdout}", t0.elapsed().as_secs_f64());
    let report = assert_bag_matches(&dir.join("png"), &rec, "/camera/image_raw/compressed");
    assert_o1_decodes_as_live(
        "--rgb",
        &dir.join("png"),
        "/O1/camera/image_raw/compressed",
        &rec,
    );
    for img in report["images"].as_object().unwrap().values() {
        assert_eq!(img["sizes"], serde_json::json!(["(640, 480, 2)"]), "{img}");
        assert_eq!(
            img["format"],
            serde_json::json!(["rgb8; png compressed bgr8"])
        );
    }
    export(run, &dir.join("raw"), &["--raw-images"]);
    let report = assert_bag_matches(&dir.join("raw"), &rec, "/camera/image_raw");
    assert_o1_decodes_as_live("--rgb", &dir.join("raw"), "/O1/camera/image_raw", &rec);
    assert_observes_as_decoded(
        &dir.join("png"),
        "/O1/camera/image_raw/compressed",
        "compressed-image",
    );
    assert_observes_as_decoded(&dir.join("raw"), "/O1/camera/image_raw", "image");
    for img in report["images"].as_object().unwrap().values() {
        assert_eq!(
            img["sizes"],
            serde_json::json!(["(640, 480, 'rgb8')"]),
            "{img}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_damaged_or_cut_recording_is_refused_naming_the_file_and_bytes() {
    let run = only_a("events");
    let dir = scratch("damaged");
    let bytes = std::fs::read(run.join("session.mcap")).unwrap();
    let mid = bytes.len() / 2;
    let mut flipped = bytes.clone();
    for b in &mut flipped[mid..mid + 64] {
        *b ^= 0x5a;
    }
    for (name, data) in [("flipped", flipped), ("cut", bytes[..mid].to_vec())] {
        let file = dir.join(format!("{name}.mcap"));
        std::fs::write(&file, &data).unwrap();
        let bag = dir.join(format!("{name}-bag"));
        let out = export_ros2(&file, &bag).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success(),
            "{name}: exported a damaged recording"
        );
        assert!(!err.contains("panicked"), "{name}: {err}");
        assert!(err.contains(&file.display().to_string()), "{name}: {err}");
        assert!(err.contains("bytes "), "{name}: {err}");
        assert!(!bag.exists(), "{name}: a partial bag was left");
    }
    // An existing bag is never overwritten.
    std::fs::create_dir_all(dir.join("taken")).unwrap();
    std::fs::write(dir.join("taken/x"), b"x").unwrap();
    let out = export_ros2(run, &dir.join("taken")).output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("not an empty directory"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Writes the bag of [`every_waggle_message_kind_reads_back_with_its_values`]: 6 tokens on
/// `/O3/tokens`, 3 frames on `/O1/frames`, 2 decisions on `/O1/decision`, 3 faults on `/O2/fault`,
/// 2 broadcasts on `/performer/broadcast`.
fn write_every_waggle_kind(bag: &Path) {
    use proto::{
        Broadcast, Decision, Fault, FaultKind, FrameEvent, ObserverId, Offer, ReleasedFrame, Site,
        SourceFrame, Token, TokenEvent,
    };
    use ros2_bag::waggle_msgs::{BroadcastMsg, DecisionMsg, FaultMsg, FrameMsg, TokenMsg};
    use ros2_bag::{BagWriter, QosProfile};

    let o = |s: &str| ObserverId::new(s).unwrap();
    let vol = QosProfile::VOLATILE;
    let mut w = BagWriter::create(bag).unwrap();

    for (seq, token) in Token::ALL.into_iter().enumerate() {
        let t = TokenEvent {
            observer: o("O3"),
            seq: seq as u64,
            token,
            confirmed_ns: 1_000_000_000 + seq as u64 * 40_000_000,
        };
        let msg = TokenMsg::from_wire(&t).unwrap();
        w.write("/O3/tokens", vol, t.confirmed_ns, &msg).unwrap();
    }
    // 0b100111: site B, quality 1, capacity 3; 0b100000: B withdrawn; 0b110101: site id 3.
    for (seq, payload) in [0b10_01_11u8, 0b10_00_00, 0b11_01_01]
        .into_iter()
        .enumerate()
    {
        let f = FrameEvent {
            observer: o("O1"),
            seq: seq as u64,
            round: 4,
            frame: ReleasedFrame {
                payload,
                token_stamps_ns: (0..17)
                    .map(|k| 5_000_000_000 + seq as u64 * 1_000_000_000 + k * 40_000_001)
                    .collect(),
            },
        };
        let msg = FrameMsg::from_wire(&f).unwrap();
        w.write("/O1/frames", vol, f.frame.final_null_ns(), &msg)
            .unwrap();
    }
    let decisions = [
        Decision {
            observer: o("O1"),
            round: 2,
            decided_ns: 12_340_000_000,
            assignment: Some(Site::B),
            sources: vec![
                SourceFrame {
                    observer: o("O1"),
                    frame_seq: 3,
                    offer: Offer::new(Site::B, 3, 1).unwrap(),
                    final_null_ns: 12_000_000_001,
                },
                SourceFrame {
                    observer: o("O1"),
                    frame_seq: 4,
                    offer: Offer::withdrawal(Site::A),
                    final_null_ns: 12_100_000_000,
                },
            ],
            allocation: [(o("O1"), Some(Site::B)), (o("O2"), None)]
                .into_iter()
                .collect(),
        },
        Decision {
            observer: o("O1"),
            round: 3,
            decided_ns: 20_000_000_000,
            assignment: None,
            sources: vec![],
            allocation: Default::default(),
        },
    ];
    for d in &decisions {
        let msg = DecisionMsg::from_wire(d).unwrap();
        w.write("/O1/decision", vol, d.decided_ns, &msg).unwrap();
    }
    let faults = [
        (
            FaultKind::Throttle {
                drop_per_mille: 250,
                delay_ms: 7,
            },
            Some(9_500_000_000),
        ),
        (FaultKind::BlackInput, None),
        (FaultKind::StreamDropout, Some(21_000_000_000)),
    ];
    for (k, (kind, until_ns)) in faults.into_iter().enumerate() {
        let f = Fault {
            observer: o("O2"),
            kind,
            from_ns: 3_000_000_000 + k as u64,
            until_ns,
        };
        let msg = FaultMsg::from_wire(&f).unwrap();
        w.write("/O2/fault", vol, f.from_ns, &msg).unwrap();
    }
    // A round's first broadcast (acquisition first) and its repeat, one offer withdrawn.
    for (tick, acquisition, offers) in [
        (
            100,
            true,
            vec![
                Offer::new(Site::A, 2, 1).unwrap(),
                Offer::withdrawal(Site::B),
            ],
        ),
        (700, false, vec![Offer::new(Site::A, 2, 1).unwrap()]),
    ] {
        let b = Broadcast {
            tick,
            round: 5,
            start_ns: tick * 40_000_000 + 1,
            offers,
            acquisition,
        };
        let msg = BroadcastMsg::from_wire(&b).unwrap();
        w.write("/performer/broadcast", vol, b.start_ns, &msg)
            .unwrap();
    }
    let summary = w.finish().unwrap();
    assert_eq!(summary.message_count, 6 + 3 + 2 + 3 + 2);
}

/// Every `waggle_msgs` kind and every value its fields can take apart from numbers (all six
/// tokens, a frame with and without a valid offer, a withdrawal, a decision for a site and one
/// for home, all three faults, with and without an end), written by the library and read back by
/// both independent readers: each message's values as `rosbags` decodes them (and
/// `mcap-ros2-support` identically), and each type's RIHS01 hash as rosbags computes it from the
/// bag's own schema. Needs no run, so it takes about a second.
#[test]
fn every_waggle_message_kind_reads_back_with_its_values() {
    use proto::Token;
    use serde_json::json;

    let dir = scratch("kinds");
    let bag = dir.join("kinds");
    write_every_waggle_kind(&bag);

    let report = check(&bag);
    assert_eq!(report["profile"], "ros2");
    assert_eq!(report["disagreements"], json!([]), "{report}");
    let counts = json!({"/O1/decision": 2, "/O1/frames": 3, "/O2/fault": 3, "/O3/tokens": 6,
                        "/performer/broadcast": 2});
    assert_eq!(report["rosbags"], counts);
    assert_eq!(report["mcap_ros2"], counts);
    assert_eq!(report["metadata"]["topics"], counts);
    assert_eq!(report["metadata"]["message_count"], 16);
    let types = report["types"].as_object().unwrap();
    let names: Vec<&str> = types.keys().map(String::as_str).collect();
    assert_eq!(
        names,
        [
            "waggle_msgs/msg/Broadcast",
            "waggle_msgs/msg/Decision",
            "waggle_msgs/msg/Fault",
            "waggle_msgs/msg/Frame",
            "waggle_msgs/msg/Token"
        ]
    );
    for (ty, t) in types {
        assert_eq!(t["hash_ok"], true, "{ty}: {t}");
        assert_eq!(t["serialization"], "cdr", "{ty}");
    }
    let time = |ns: u64| json!({"sec": ns / 1_000_000_000, "nanosec": ns % 1_000_000_000});
    let header = |ns: u64, frame: &str| json!({"stamp": time(ns), "frame_id": frame});
    let values = &report["waggle"];

    let tokens: Vec<Value> = Token::ALL
        .into_iter()
        .enumerate()
        .map(|(seq, token)| {
            let ns = 1_000_000_000 + seq as u64 * 40_000_000;
            json!({"header": header(ns, "O3/camera_optical"), "observer": "O3", "seq": seq,
                   "token": seq, "label": token.label()})
        })
        .collect();
    assert_eq!(values["/O3/tokens"], json!(tokens));
    let labels: Vec<&str> = Token::ALL.iter().map(|t| t.label()).collect();
    assert_eq!(labels, ["NULL", "START", "0", "1", "END", "?"]);

    let offer = |site: &str, quality: u8, capacity: u8, withdrawn: bool| json!({"site": site, "quality": quality, "capacity": capacity, "withdrawn": withdrawn});
    let frames: Vec<Value> = [
        ("100111", true, offer("B", 1, 3, false)),
        ("100000", true, offer("B", 0, 0, true)),
        ("110101", false, offer("", 0, 0, false)),
    ]
    .into_iter()
    .enumerate()
    .map(|(seq, (bits, valid, offer))| {
        let stamps: Vec<Value> = (0..17)
            .map(|k| time(5_000_000_000 + seq as u64 * 1_000_000_000 + k * 40_000_001))
            .collect();
        json!({"header": header(5_000_000_000 + seq as u64 * 1_000_000_000 + 16 * 40_000_001,
                                "O1/camera_optical"),
               "observer": "O1", "seq": seq, "round": 4,
               "payload": u8::from_str_radix(bits, 2).unwrap(), "bits": bits,
               "offer_valid": valid, "offer": offer, "token_stamps": stamps})
    })
    .collect();
    assert_eq!(values["/O1/frames"], json!(frames));

    assert_eq!(
        values["/O1/decision"],
        json!([
            {"header": header(12_340_000_000, "O1"), "observer": "O1", "round": 2,
             "assignment": "B",
             "sources": [
                 {"observer": "O1", "frame_seq": 3, "offer": offer("B", 3, 1, false),
                  "final_null": time(12_000_000_001)},
                 {"observer": "O1", "frame_seq": 4, "offer": offer("A", 0, 0, true),
                  "final_null": time(12_100_000_000)}],
             "allocation": [{"observer": "O1", "site": "B"}, {"observer": "O2", "site": ""}]},
            {"header": header(20_000_000_000, "O1"), "observer": "O1", "round": 3,
             "assignment": "", "sources": [], "allocation": []}
        ])
    );

    assert_eq!(
        values["/O2/fault"],
        json!([
            {"header": header(3_000_000_000, "O2"), "observer": "O2", "kind": 2,
             "drop_per_mille": 250, "delay_ms": 7, "active_from": time(3_000_000_000),
             "has_until": true, "active_until": time(9_500_000_000)},
            {"header": header(3_000_000_001, "O2"), "observer": "O2", "kind": 0,
             "drop_per_mille": 0, "delay_ms": 0, "active_from": time(3_000_000_001),
             "has_until": false, "active_until": time(0)},
            {"header": header(3_000_000_002, "O2"), "observer": "O2", "kind": 1,
             "drop_per_mille": 0, "delay_ms": 0, "active_from": time(3_000_000_002),
             "has_until": true, "active_until": time(21_000_000_000)}
        ])
    );

    assert_eq!(
        values["/performer/broadcast"],
        json!([
            {"header": header(4_000_000_001, "performer"), "round": 5, "acquisition": true,
             "offers": [offer("A", 2, 1, false), offer("B", 0, 0, true)]},
            {"header": header(28_000_000_001, "performer"), "round": 5, "acquisition": false,
             "offers": [offer("A", 2, 1, false)]}
        ])
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The larger target: a whole nominal-3 mission with event cameras (`--full`).
#[test]
#[ignore = "a whole nominal-3 mission (≈ 5 min); deploy/test.sh --full"]
fn nominal_3_events_exports_a_bag_both_readers_read() {
    let run = run_case("nominal-3", "nominal-3", "events");
    let bag = run.parent().unwrap().join("bag");
    let t0 = std::time::Instant::now();
    let stdout = export(&run, &bag, &[]);
    eprintln!("export: {:.2} s\n{stdout}", t0.elapsed().as_secs_f64());
    let rec = recorded(&run);
    assert!(rec.counts.keys().any(|t| t.ends_with("/decision")));
    assert_bag_matches(&bag, &rec, "");
    let _ = std::fs::remove_dir_all(run.parent().unwrap());
}
