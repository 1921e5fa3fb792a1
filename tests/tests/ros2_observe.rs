//! `waggle observe`: a live observer on a camera's ROS 2 topic, fed by independent code as a
//! camera driver on `rmw_zenoh` would feed it.
//!
//! `tools/ros2/publish_events.py` (Eclipse Zenoh's own Python client and PyPI `rosbags`' CDR
//! serializer, in the venv `deploy/setup.sh` makes) listens where `rmw_zenohd` would, waits for
//! the observer's subscription token, then declares a driver node and its publisher and
//! publishes an EVT 3.0 file's words as `event_camera_msgs/msg/EventPacket` messages cut at
//! arbitrary word boundaries, as Prophesee's `metavision_driver` does; then it withdraws its
//! publisher, which ends the observer. It counts the events it sent with its own decoder and
//! decodes, with rosbags, what the observer publishes back.
//!
//! - A recorded Waggle session (`waggle link --events-raw`, a viewpoint and payload no other
//!   test uses): the live decode equals `waggle decode` of the same file — tokens, frames and
//!   payloads — and the tokens and frames come back as `waggle_msgs`. Malformed messages on
//!   the topic are refused and counted without stopping the observer.
//! - The real EVK4 recording (`evt3.raw` of the faery source package): every event arrives,
//!   the count equals the file's and the publisher's, and the decode equals `waggle decode`'s.

use std::path::{Path, PathBuf};
use std::time::Duration;

use serde_json::Value;
use waggle_tests::{RosCameraDriver, export_ros2, succeed, waggle, workspace_root};

const DOMAIN: u32 = 17;
const TOPIC: &str = "/event_camera/events";

fn scratch(name: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("waggle-ros2-observe-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Publishes `source` while `waggle observe VIEW…` listens; both reports.
fn observe(dir: &Path, source: &Path, view: &[&str], publisher_args: &[&str]) -> (Value, Value) {
    let driver = RosCameraDriver::start(dir, DOMAIN, TOPIC, source, publisher_args);
    let observer = waggle()
        .args(["observe", "--topic", TOPIC, "--ros2-domain"])
        .arg(DOMAIN.to_string())
        .args([
            "--ros2-router",
            &driver.endpoint,
            "--idle-s",
            "60",
            "--json",
        ])
        .args(view)
        .output()
        .unwrap();
    let published = driver.finish(Duration::from_secs(60));
    assert!(
        observer.status.success(),
        "waggle observe: {}",
        String::from_utf8_lossy(&observer.stderr)
    );
    let observed: Value = serde_json::from_slice(&observer.stdout).expect("JSON output");
    (observed, published)
}

fn decode(file: &Path, view: &[&str]) -> Value {
    let out = succeed(
        waggle()
            .args(["decode", "--events"])
            .arg(file)
            .args(view)
            .arg("--json"),
        &format!("waggle decode --events {}", file.display()),
    );
    serde_json::from_slice(&out.stdout).expect("JSON output")
}

/// The observer ended because the driver left, every message arrived, and the decode equals
/// `waggle decode`'s of the same file.
fn assert_live_equals_file(observed: &Value, published: &Value, file: &Value, refused: u64) {
    assert_eq!(observed["ended"], "publishers left", "{observed}");
    assert_eq!(observed["publishers"], 1, "{observed}");
    assert_eq!(
        observed["messages"].as_u64(),
        published["messages"].as_u64().map(|n| n + refused),
        "{observed}"
    );
    assert_eq!(observed["refused"].as_u64(), Some(refused), "{observed}");
    assert_eq!(observed["events"], published["events"], "{observed}");
    assert_eq!(observed["events"], file["events"], "{observed}");
    assert_eq!(observed["events_late"], 0, "{observed}");
    assert_eq!(observed["packets"], file["packets"], "{observed}");
    assert_eq!(observed["decoded"], file["decoded"], "{observed}");
}

/// What came back on `/O1/tokens` and `/O1/frames`, decoded by rosbags.
fn received<'a>(published: &'a Value, topic: &str) -> Vec<&'a Value> {
    published["received"]
        .as_object()
        .unwrap()
        .iter()
        .filter(|(key, _)| key.starts_with(&format!("{DOMAIN}/{}/", topic.trim_matches('/'))))
        .map(|(_, v)| v)
        .collect()
}

#[test]
fn a_recorded_session_published_live_decodes_as_the_file() {
    let dir = scratch("session");
    let view = ["--viewpoint=22,3,1.55"];
    let payload = "100110";
    let link = succeed(
        waggle()
            .args([
                "link",
                "--modality",
                "events",
                view[0],
                "--payload",
                payload,
            ])
            .arg("--events-raw")
            .arg(&dir)
            .arg("--json"),
        "waggle link --events-raw",
    );
    let link: Value = serde_json::from_slice(&link.stdout).unwrap();
    assert_eq!(
        link["observers"]["O1"]["payloads"],
        serde_json::json!([payload])
    );
    let raw = dir.join("O1.raw");
    let file = decode(&raw, &view);
    assert_eq!(file["decoded"]["payloads"], serde_json::json!([payload]));
    // Small messages (many word boundaries cut), and three malformed ones after the first.
    let (observed, published) = observe(&dir, &raw, &view, &["--chunk-bytes", "3002", "--junk"]);
    assert_live_equals_file(&observed, &published, &file, 3);
    let refusals = observed["refusals"].to_string();
    for why in ["encoding \\\"mono\\\"", "sensor 320×240 after 640×480"] {
        assert!(refusals.contains(why), "{why}: {refusals}");
    }
    // The tokens and frames, back as ROS 2 messages that rosbags decodes.
    let tokens = received(&published, "/O1/tokens");
    let frames = received(&published, "/O1/frames");
    assert_eq!(tokens.len(), 1, "{}", published["received"]);
    assert_eq!(frames.len(), 1, "{}", published["received"]);
    let n_tokens = file["decoded"]["tokens"].as_array().unwrap().len() as u64;
    assert_eq!(tokens[0]["count"].as_u64(), Some(n_tokens));
    assert_eq!(tokens[0]["decoded"].as_u64(), Some(n_tokens));
    assert_eq!(frames[0]["count"], 1);
    assert_eq!(frames[0]["decoded"], 1);
    assert_eq!(
        observed["published"]["/O1/tokens"].as_u64(),
        Some(n_tokens),
        "{observed}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_real_evk4_recording_arrives_whole() {
    let file = workspace_root().join("third_party/faery/data/evt3.raw");
    assert!(
        file.is_file(),
        "{} missing: run `bash deploy/setup.sh`",
        file.display()
    );
    let dir = scratch("evk4");
    let view = ["--observer=O2"];
    let decoded = decode(&file, &view);
    assert_eq!(decoded["events"], 1_218_618, "faery's count: {decoded}");
    let (observed, published) = observe(&dir, &file, &view, &[]);
    assert_live_equals_file(&observed, &published, &decoded, 0);
    assert_eq!(observed["width_px"], 1280);
    assert_eq!(observed["height_px"], 720);
    assert_eq!(observed["remapped"], true);
    assert_eq!(observed["events_outside"], decoded["events_outside"]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_arguments_are_refused_naming_them() {
    for (args, named) in [
        (vec!["--topic", "no-slash"], "no-slash"),
        (vec!["--topic", "/t", "--tail-s=-1"], "--tail-s"),
        (vec!["--topic", "/t", "--idle-s=-2"], "--idle-s"),
        (vec!["--topic", "/t", "--id", "O 1"], "--id"),
        (
            vec!["--topic", "/t", "--ros2-router", "nonsense"],
            "nonsense",
        ),
    ] {
        let out = waggle()
            .arg("observe")
            .args(&args)
            .args(["--observer", "O1"])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} accepted");
        assert!(stderr.contains(named), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    }
}

#[test]
#[ignore = "two whole only-a missions as processes (≈ 40 s): deploy/test.sh --full"]
fn a_session_camera_on_a_ros2_topic_flies_as_the_simulated_one() {
    let dir = scratch("session-camera");
    let reference = dir.join("simulated");
    succeed(
        waggle()
            .args(["run", "only-a", "--modality", "events", "--quiet", "--out"])
            .arg(&reference),
        "waggle run only-a",
    );
    let bag = dir.join("bag");
    succeed(&mut export_ros2(&reference, &bag), "waggle export ros2");
    // O2's recorded camera, republished by a driver on a topic of its own.
    let topic = "/camera_o2/events";
    let driver = RosCameraDriver::start(
        &dir,
        DOMAIN,
        topic,
        &bag,
        &["--bag-topic", "/O2/events", "--listen-s", "2"],
    );
    let real = dir.join("ros2-camera");
    let run = waggle()
        .args(["run", "only-a", "--modality", "events", "--quiet", "--json"])
        .args(["--ros2-domain", &DOMAIN.to_string(), "--ros2-router"])
        .arg(&driver.endpoint)
        .args(["--ros2-camera", &format!("O2={topic}"), "--out"])
        .arg(&real)
        .output()
        .unwrap();
    let published = driver.finish(Duration::from_secs(120));
    assert!(
        run.status.success(),
        "waggle run --ros2-camera: {}\n{}",
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr)
    );
    let read = |run: &Path| -> Value {
        serde_json::from_slice(&std::fs::read(run.join("observers.json")).unwrap()).unwrap()
    };
    assert_eq!(read(&real), read(&reference), "O2 on the ROS 2 camera");
    // O2's camera published the driver's packets; the live view carried them and O2's first
    // tokens back to the driver while it listened.
    let log = std::fs::read_to_string(real.join("logs/camera-O2.log")).unwrap_or_default();
    assert!(!log.contains("camera message refused"), "{log}");
    let received = published["received"].as_object().unwrap();
    for needed in ["O2/tokens", "O2/events"] {
        assert!(
            received
                .keys()
                .any(|k| k.starts_with(&format!("{DOMAIN}/{needed}/"))),
            "{needed}: {:?}",
            received.keys().collect::<Vec<_>>()
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
