//! The live view and the recording's view channels, checked with Foxglove's own libraries:
//! a real Foxglove WebSocket client (`@foxglove/ws-protocol`, run by node) connects to
//! `waggle run --live PORT` while the mission flies and must receive valid messages on every
//! channel advertised (images of every observer, poses, the 3D scene, the log), each decoded
//! with the official definitions of `@foxglove/schemas`, not the server's; afterwards
//! `@mcap/core` and the official Python `mcap` reader read the recording, and every view message
//! in it validates against the same official definitions (`tests/js/`).

use std::path::PathBuf;
use std::process::Stdio;
use std::time::{Duration, Instant};

use serde_json::Value;
use waggle_tests::{assert_recording_validates, node_client, waggle_with_nodes};

#[test]
fn a_live_client_receives_every_view_channel_and_the_recording_validates() {
    let dir: PathBuf = std::env::temp_dir().join(format!("waggle-view-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let port = waggle_tests::free_port();
    let mut run = waggle_with_nodes()
        .args(["run", "only-a", "--modality", "events", "--quiet", "--live"])
        .arg(port.to_string())
        .arg("--out")
        .arg(&dir)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start waggle run --live");
    // Three observers' event images, poses, the scene and the log: at least six channels.
    let client = node_client("live_client.mjs")
        .args(["--url", &format!("ws://127.0.0.1:{port}")])
        .args(["--timeout-s", "120", "--min-channels", "6"])
        .output()
        .expect("run the live client");
    let report = String::from_utf8_lossy(&client.stdout).into_owned();
    let deadline = Instant::now() + Duration::from_secs(300);
    while run.try_wait().expect("poll waggle run").is_none() {
        assert!(Instant::now() < deadline, "waggle run --live did not end");
        std::thread::sleep(Duration::from_millis(200));
    }
    let out = run.wait_with_output().expect("waggle run output");
    assert!(
        out.status.success(),
        "waggle run --live failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        client.status.success(),
        "live client: {report}{}",
        String::from_utf8_lossy(&client.stderr)
    );
    let live: Value = serde_json::from_str(&report).expect("the live client prints JSON");
    let channels = live["channels"].as_object().expect("channels");
    for (topic, schema) in [
        ("/view/O1/events", "foxglove.RawImage"),
        ("/view/O2/events", "foxglove.RawImage"),
        ("/view/O3/events", "foxglove.RawImage"),
        ("/view/tf", "foxglove.FrameTransforms"),
        ("/view/scene", "foxglove.SceneUpdate"),
        ("/view/log", "foxglove.Log"),
    ] {
        let c = &channels
            .get(topic)
            .unwrap_or_else(|| panic!("{topic} not advertised live: {report}"));
        assert_eq!(c["schemaName"], schema, "{topic}");
        assert!(c["messages"].as_u64() > Some(0), "{topic}: {report}");
        assert_eq!(c["invalid"], 0, "{topic}: {report}");
    }

    let recorded = assert_recording_validates(&dir.join("session.mcap"));
    let topics = recorded["topics"].as_object().expect("topics");
    for topic in channels.keys() {
        assert!(
            topics
                .get(topic)
                .is_some_and(|t| t["messages"].as_u64() > Some(0)),
            "{topic} is live but not in the recording: {recorded}"
        );
    }
}
