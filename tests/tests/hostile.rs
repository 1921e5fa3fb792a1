//! A hostile bus: a rogue Zenoh client (the `zenoh` crate itself, not Waggle's `bus` library)
//! joins a run and publishes junk — random, empty, truncated, wrong-version and huge payloads —
//! on every key any node reads, and on keys outside the grammar, for the whole run. The run
//! must pass with the very `observers.json` of an undisturbed run (the golden digest), and
//! every process must count what it dropped in `summary.json`.

use std::path::Path;
use std::process::Stdio;
use std::time::{Duration, Instant};

use deploy::run_dir::RunSummary;
use proto::{ObserverId, RejectReason, Role};
use waggle_tests::waggle_with_nodes;
use zenoh::Wait;

mod golden_runs;
use golden_runs::{golden_entry, sha256_hex};

/// Every key some Waggle process reads (and a few it must ignore), for `session`.
fn target_keys(session: &str, observers: usize) -> Vec<String> {
    let k = proto::Keys::new(session).unwrap();
    let mut out = vec![
        k.clock(),
        k.sim_state(),
        k.sim_contacts(),
        k.performer_setpoint(),
        k.truth_performer(),
        k.sched_cmd(),
        k.sched_broadcast(),
        k.sched_session(),
        k.sched_report(),
        k.rejects(Role::Sim, "sim").unwrap(),
        format!("{}/bogus/key", k.prefix()),
        format!("{}/observer/O9/status", k.prefix()),
    ];
    for i in 0..observers {
        let o = ObserverId::from_index(i);
        out.extend([
            k.sensor_events(&o),
            k.sensor_rgb(&o),
            k.fault(&o),
            k.observer_status(&o),
            k.observer_tokens(&o),
            k.observer_frames(&o),
            k.observer_decision(&o),
            k.observer_track(&o),
        ]);
    }
    out
}

/// The junk payloads: each is refused by `proto::decode` for every message type.
fn junk(round: u64) -> Vec<Vec<u8>> {
    // A deterministic byte stream (splitmix64): random-looking, reproducible.
    let mut x = round.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5_4A32_D192_ED03;
    let mut random = vec![0u8; 64];
    for b in &mut random {
        x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = x;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        *b = (z ^ (z >> 31)) as u8;
    }
    // Wire version 19366 (the probe's), never this build's.
    random[..2].copy_from_slice(&19366u16.to_le_bytes());
    let valid = proto::encode(&proto::ClockTick::at(5).unwrap());
    let truncated = valid[..valid.len() - 3].to_vec();
    let mut wrong_version = valid.clone();
    wrong_version[..2].copy_from_slice(&(proto::FORMAT_VERSION + 1).to_le_bytes());
    vec![random, Vec::new(), truncated, wrong_version, vec![0x02]]
}

/// A rogue peer publishing junk on `keys` through `endpoint` until `done()` (bounded).
fn flood(endpoint: &str, keys: &[String], done: impl Fn() -> bool) -> u64 {
    let mut config = zenoh::Config::default();
    config.insert_json5("mode", "\"peer\"").unwrap();
    config
        .insert_json5("scouting/multicast/enabled", "false")
        .unwrap();
    config
        .insert_json5("connect/endpoints", &format!("[\"{endpoint}\"]"))
        .unwrap();
    config.insert_json5("listen/endpoints", "[]").unwrap();
    let session = zenoh::open(config).wait().expect("rogue session");
    let huge = vec![0xAB; 2 << 20];
    let mut sent = 0u64;
    let deadline = Instant::now() + Duration::from_secs(900);
    let mut round = 0u64;
    while !done() && Instant::now() < deadline {
        for key in keys {
            let mut payloads = junk(round);
            if round == 3 {
                payloads.push(huge.clone());
            }
            for p in payloads {
                if session.put(key.as_str(), p).wait().is_ok() {
                    sent += 1;
                }
            }
        }
        round += 1;
        std::thread::sleep(Duration::from_millis(250));
    }
    session.close().wait().ok();
    sent
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// Waits for `child`, killing it and failing after `limit` (a hang must not stall CI).
fn wait_bounded(child: &mut std::process::Child, limit: Duration) -> std::process::ExitStatus {
    let deadline = Instant::now() + limit;
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return status;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("waggle run did not end within {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(200));
    }
}

fn read_summary(dir: &Path) -> RunSummary {
    let text = std::fs::read_to_string(dir.join("summary.json"))
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    serde_json::from_str(&text).unwrap()
}

#[test]
fn junk_on_every_key_leaves_the_run_passing_with_identical_observers_and_counted_rejects() {
    let (case, modality) = ("only-a", "events");
    let session = format!("hostile-{}", std::process::id());
    let dir = std::env::temp_dir().join(format!("waggle-{session}"));
    let _ = std::fs::remove_dir_all(&dir);
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let log = std::env::temp_dir().join(format!("waggle-{session}.log"));
    let mut run = waggle_with_nodes()
        .args(["run", case, "--modality", modality, "--quiet", "--no-auth"])
        .args(["--session", &session, "--listen", &endpoint, "--out"])
        .arg(&dir)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&log).unwrap())
        .stderr(Stdio::from(std::fs::File::create(log.with_extension("err")).unwrap()))
        .spawn()
        .expect("start waggle run");
    // Let the launcher open its listener before the rogue connects.
    std::thread::sleep(Duration::from_millis(500));
    let keys = target_keys(&session, 3);
    let finished = std::sync::atomic::AtomicBool::new(false);
    let (sent, out) = std::thread::scope(|s| {
        let rogue = s.spawn(|| {
            flood(&endpoint, &keys, || {
                finished.load(std::sync::atomic::Ordering::SeqCst)
            })
        });
        let status = wait_bounded(&mut run, Duration::from_secs(900));
        finished.store(true, std::sync::atomic::Ordering::SeqCst);
        (rogue.join().unwrap(), status)
    });
    let context = format!(
        "outputs in {}\nstdout:\n{}\nstderr:\n{}",
        dir.display(),
        std::fs::read_to_string(&log).unwrap_or_default(),
        std::fs::read_to_string(log.with_extension("err")).unwrap_or_default()
    );
    assert!(out.success(), "{context}");
    assert!(sent > 1000, "the rogue sent only {sent} messages");
    let summary = read_summary(&dir);
    assert!(summary.mission.pass, "{:?}\n{context}", summary.mission.reasons);
    let want = golden_entry(case, modality);
    let observers = std::fs::read(dir.join("observers.json")).unwrap();
    assert_eq!(
        sha256_hex(&observers),
        want["observers_sha256"].as_str().unwrap(),
        "observers.json differs from the undisturbed run\n{context}"
    );
    let count = |process: &str, key: &str, reason: RejectReason| -> u64 {
        summary
            .rejects
            .get(process)
            .into_iter()
            .flatten()
            .filter(|c| c.key == key && c.reason == reason)
            .map(|c| c.count)
            .sum()
    };
    let undecodable = RejectReason::Undecodable;
    for (process, key) in [
        ("sim", "sched/cmd"),
        ("sim", "performer/setpoint"),
        ("scheduler", "sim/state"),
        ("scheduler", "observer/O2/status"),
        ("performer", "sched/broadcast"),
        ("camera-O1", "sim/state"),
        ("camera-O1", "fault/O1"),
        ("observer-O2", "clock"),
        ("observer-O2", "sched/session"),
        ("observer-O2", "sensor/O2/events"),
        ("launcher", "clock"),
        ("launcher", "observer/O2/status"),
        ("launcher", "fault/O3"),
        ("launcher", "rejects/sim/sim"),
    ] {
        assert!(
            count(process, key, undecodable) > 0,
            "{process} counted no undecodable message on {key}: {:?}",
            summary.rejects.get(process)
        );
    }
    assert!(count("observer-O1", "sensor/O1/rgb", RejectReason::UnexpectedKey) > 0);
    assert!(count("scheduler", "observer/O9/status", RejectReason::UnexpectedKey) > 0);
    assert!(summary.faults_seen.is_empty(), "{:?}", summary.faults_seen);
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_file(&log);
    let _ = std::fs::remove_file(log.with_extension("err"));
}
