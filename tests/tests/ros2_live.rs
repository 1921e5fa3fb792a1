//! The live ROS 2 view (`waggle run --ros2-domain N --ros2-router ENDPOINT`), received by
//! independent code as a ROS 2 node on `rmw_zenoh` would receive it.
//!
//! `tools/ros2/check_live.py` (Eclipse Zenoh's own Python client and PyPI `rosbags`, in the venv
//! `deploy/setup.sh` makes) listens where `rmw_zenohd` would, while `only-a` flies cut to its
//! first 16 s of sim time (both modalities, ≈ 5–10 s each). Every sample must sit on the key
//! `<domain>/<topic>/<pkg>::msg::dds_::<Type>_/<RIHS01 hash>` with rosbags' own hash of the type,
//! decode with rosbags' CDR deserializer, and carry an attachment Zenoh's deserializer reads as
//! (sequence number 1, 2, 3…, source timestamp, one 16-byte GID per publisher). The liveliness
//! tokens must name the node and each publisher (topic, type, hash, QoS) as the design document
//! lays them out, each GID must be its token's, and every token must be withdrawn at the end.
//! Then the run is exported as a bag: the live payloads of every topic must equal the bag's,
//! byte for byte.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;
use sha2::{Digest, Sha256};
use waggle_tests::{export_ros2, succeed, waggle, workspace_root};

const DOMAIN: u32 = 42;

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("waggle-ros2-live-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The venv's Python with Eclipse Zenoh's client and rosbags.
fn python() -> PathBuf {
    waggle_tests::venv_python_with("zenoh.ext, rosbags")
}

fn short_case(dir: &Path) -> PathBuf {
    let case = dir.join("only-a-short.toml");
    std::fs::write(
        &case,
        "name = \"only-a-short\"\nobservers = 3\nmodalities = [\"rgb\", \"events\"]\n\
         offer_sites = [\"A\"]\ntime_limit_s = 16\n\n[expected]\nmessages = [0, 0, 0]\n\
         work_units = 0\nservices = { O1 = [], O2 = [], O3 = [] }\n",
    )
    .unwrap();
    case
}

/// Runs the case with the live view into `dir/run` while check_live.py listens; its report.
fn run_watched(dir: &Path, modality: &str) -> Value {
    let endpoint = format!("tcp/127.0.0.1:{}", waggle_tests::free_port());
    let live_json = dir.join("live.json");
    let mut listener = Command::new(python())
        .arg(workspace_root().join("tools/ros2/check_live.py"))
        .args(["listen", &endpoint, &DOMAIN.to_string()])
        .arg(&live_json)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(listener.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    assert_eq!(line.trim(), "ready", "check_live.py did not start");
    let case = short_case(dir);
    let run = waggle()
        .arg("run")
        .arg(&case)
        .args(["--modality", modality, "--quiet", "--ros2-domain"])
        .arg(DOMAIN.to_string())
        .args(["--ros2-router", &endpoint, "--out"])
        .arg(dir.join("run"))
        .output()
        .unwrap();
    drop(listener.stdin.take()); // the listener reports once its input closes
    let deadline = Instant::now() + Duration::from_secs(60);
    while listener.try_wait().unwrap().is_none() {
        assert!(Instant::now() < deadline, "check_live.py did not finish");
        std::thread::sleep(Duration::from_millis(100));
    }
    assert!(
        run.status.success(),
        "waggle run: {}",
        String::from_utf8_lossy(&run.stderr)
    );
    serde_json::from_slice(&std::fs::read(&live_json).unwrap()).unwrap()
}

/// The checks on what the listener received, and the comparison with the exported bag.
fn check_live(dir: &Path, live: &Value, modality: &str) {
    let samples = live["samples"].as_object().unwrap();
    let put: Vec<&str> = live["tokens"]["put"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t.as_str().unwrap())
        .collect();
    let deleted: Vec<&str> = live["tokens"]["delete"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t.as_str().unwrap())
        .collect();
    assert_eq!(put, deleted, "every token is withdrawn at the end");
    let prefix = format!("@ros2_lv/{DOMAIN}/");
    let node: Vec<&&str> = put
        .iter()
        .filter(|t| t.ends_with("/0/0/NN/%/%/waggle_recorder"))
        .collect();
    assert_eq!(node.len(), 1, "{put:?}");
    let zid = node[0]
        .strip_prefix(&prefix)
        .unwrap()
        .split('/')
        .next()
        .unwrap();
    for (key, s) in samples {
        let parts: Vec<&str> = key.split('/').collect();
        assert_eq!(parts[0], DOMAIN.to_string());
        let (dds, hash) = (parts[parts.len() - 2], parts[parts.len() - 1]);
        let topic = parts[1..parts.len() - 2].join("%");
        let token: Vec<&&str> = put
            .iter()
            .filter(|t| {
                t.starts_with(&format!("{prefix}{zid}/0/"))
                    && t.contains(&format!("/MP/%/%/waggle_recorder/%{topic}/{dds}/{hash}/"))
            })
            .collect();
        assert_eq!(token.len(), 1, "{key}: {put:?}");
        let gid: String = Sha256::digest(token[0].as_bytes())[..16]
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        let count = s["count"].as_u64().unwrap();
        assert!(count > 0);
        assert_eq!(s["decoded"].as_u64(), Some(count), "{key}: {}", s["errors"]);
        assert_eq!(s["errors"], Value::Array(vec![]), "{key}");
        for check in ["seqs_ok", "one_gid", "stamps_ok"] {
            assert_eq!(s[check], true, "{key}: {check}");
        }
        assert_eq!(
            s["gid"].as_str(),
            Some(gid.as_str()),
            "{key}: its token's GID"
        );
    }
    assert_eq!(
        put.len(),
        samples.len() + 1,
        "one token per topic and the node's"
    );

    let bag = dir.join("bag");
    succeed(
        &mut export_ros2(&dir.join("run"), &bag),
        "waggle export ros2",
    );
    let out = succeed(
        Command::new(python())
            .arg(workspace_root().join("tools/ros2/check_live.py"))
            .arg("compare")
            .arg(dir.join("live.json"))
            .arg(&bag),
        "check_live.py compare",
    );
    let cmp: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(cmp["only_live"], Value::Array(vec![]), "{cmp}");
    assert_eq!(cmp["only_bag"], Value::Array(vec![]), "{cmp}");
    let topics = cmp["topics"].as_object().unwrap();
    for (topic, t) in topics {
        assert_eq!(t["same"], true, "{topic}: {t}");
    }
    let camera = if modality == "rgb" {
        "/O1/camera/image_raw/compressed"
    } else {
        "/O1/events"
    };
    for needed in [
        camera,
        "/O1/camera/camera_info",
        "/tf",
        "/tf_static",
        "/O1/tokens",
    ] {
        assert!(topics.contains_key(needed), "{needed}: {cmp}");
    }
}

#[test]
fn a_ros2_node_on_zenoh_receives_the_run_as_the_bag_holds_it() {
    for modality in ["events", "rgb"] {
        let dir = scratch(modality);
        let live = run_watched(&dir, modality);
        check_live(&dir, &live, modality);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
