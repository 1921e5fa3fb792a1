//! The lockstep's results do not depend on when the transport delivers a message (issue 30).
//!
//! Every process of a run inherits `WAGGLE_TEST_DELAY` (the bus's test shim, `bus::delay`): the
//! publications on the chosen keys leave tens to hundreds of milliseconds — several ticks of
//! wall time — after they were put, each key in its own order, while everything else goes at
//! once. So the scheduler's session controls reach the observers after the clock and the sensor
//! packets of the next tick, one camera's packets after everyone else's, the clock after the
//! state, and the observers' tokens, frames and decisions reach the launcher and the recorder
//! long after the statuses that closed their ticks. The observers' outputs must not change.
//!
//! The same holds over the other transport: `quic/` with the session's certificates.
//!
//! - default suite: `only-a` cut to 16 s of sim time, plain, with the delays and over `quic/`:
//!   byte-identical `observers.json` and sensor digests (≈ 30 s);
//! - `--full`: the golden `only-a` and `nominal-3` runs of both modalities under the delays and
//!   over `quic/` equal `tests/golden/frozen.toml` (`only-a` ≈ 3 min each under the delays, whose
//!   session controls pace every tick, ≈ 40 s over `quic/`; `nominal-3` longer). The chain of two
//!   routers is `multihost.rs`'s.

use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::sync::Mutex;

use deploy::run_dir::RunSummary;
use waggle_tests::{succeed, waggle_with_nodes};

mod golden_runs;
use golden_runs::{golden_entry, sha256_hex};

/// Keys on every consumer's path: the observers' session controls, one camera's packets and the
/// clock (ticks wait for them), and what the launcher and recorder gather (nothing waits).
const DELAYS: &str = "sched/session=30;sensor/O2/*=20;clock=10;\
                      observer/*/tokens=300;observer/*/frames=300;observer/*/decision=300";

/// One run at a time: each keeps both cores busy.
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("waggle-order-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `waggle run CASE --modality M` into `dir/run`, with `delays` in the environment (none when
/// empty); the run's summary and `observers.json`.
fn run(case: &str, modality: &str, dir: &Path, delays: &str) -> (RunSummary, Vec<u8>) {
    run_with(case, modality, dir, delays, &[])
}

/// [`run`] with extra `waggle run` arguments.
fn run_with(
    case: &str,
    modality: &str,
    dir: &Path,
    delays: &str,
    extra: &[&str],
) -> (RunSummary, Vec<u8>) {
    let _turn = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let out = dir.join("run");
    let mut cmd = waggle_with_nodes();
    cmd.args(["run", case, "--modality", modality, "--quiet", "--out"])
        .arg(&out)
        .args(extra)
        .stdin(Stdio::null());
    if delays.is_empty() {
        cmd.env_remove(bus::delay::DELAY_ENV);
    } else {
        cmd.env(bus::delay::DELAY_ENV, delays);
    }
    succeed(
        &mut cmd,
        &format!("waggle run {case} --modality {modality} ({delays:?})"),
    );
    let summary = serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap())
        .expect("summary.json is a RunSummary");
    if !delays.is_empty() {
        let log = std::fs::read_to_string(out.join("logs/observer-O1.log")).unwrap();
        assert!(log.contains("test shim"), "the shim did not engage:\n{log}");
    }
    (summary, std::fs::read(out.join("observers.json")).unwrap())
}

#[test]
fn delayed_keys_change_nothing_in_a_short_run() {
    let dir = scratch("short");
    let case = dir.join("only-a-16s.toml");
    std::fs::write(
        &case,
        "name = \"only-a-16s\"\nobservers = 3\nmodalities = [\"rgb\", \"events\"]\n\
         offer_sites = [\"A\"]\ntime_limit_s = 16\n\n[expected]\n\
         messages = [0, 0, 0]\nwork_units = 0\nservices = { O1 = [], O2 = [], O3 = [] }\n",
    )
    .unwrap();
    let case = case.to_str().unwrap();
    let (plain, plain_obs) = run(case, "events", &dir.join("plain"), "");
    let (delayed, delayed_obs) = run(case, "events", &dir.join("delayed"), DELAYS);
    assert_eq!(plain.sensor_digests, delayed.sensor_digests);
    assert!(
        plain.missing_packets.is_empty(),
        "{:?}",
        plain.missing_packets
    );
    assert!(
        delayed.missing_packets.is_empty(),
        "{:?}",
        delayed.missing_packets
    );
    // Tokens were confirmed within the 16 s, so the comparison has content.
    assert!(
        String::from_utf8_lossy(&plain_obs).contains("confirmed_ns"),
        "no token in 16 s"
    );
    assert!(plain_obs == delayed_obs, "observers.json differs");
    // The encrypted transport: QUIC with the session's certificates (mutual TLS).
    let (quic, quic_obs) = run_with(case, "events", &dir.join("quic"), "", QUIC);
    assert_eq!(plain.sensor_digests, quic.sensor_digests);
    assert!(plain_obs == quic_obs, "observers.json differs over quic/");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The session router on QUIC (loopback, a free port): every node dials it with mutual TLS.
const QUIC: &[&str] = &["--listen", "quic/127.0.0.1:0"];

fn golden_under(case: &str, modality: &str, delays: &str, extra: &[&str]) {
    let want = golden_entry(case, modality);
    let dir = scratch(&format!("golden-{case}-{modality}-{}", extra.len()));
    let (summary, observers) = run_with(case, modality, &dir, delays, extra);
    let digests: std::collections::BTreeMap<String, String> = want["sensor_digests"]
        .as_table()
        .unwrap()
        .iter()
        .map(|(o, d)| (o.clone(), d.as_str().unwrap().to_string()))
        .collect();
    assert_eq!(summary.sensor_digests, digests);
    assert_eq!(
        sha256_hex(&observers),
        want["observers_sha256"].as_str().unwrap(),
        "{case} {modality}: observers.json changed (delays {delays:?}, {extra:?}; outputs in {})",
        dir.display()
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
#[ignore = "≈ 3 min: deploy/test.sh --full"]
fn golden_only_a_events_under_delays() {
    golden_under("only-a", "events", DELAYS, &[]);
}

#[test]
#[ignore = "≈ 3 min: deploy/test.sh --full"]
fn golden_only_a_rgb_under_delays() {
    golden_under("only-a", "rgb", DELAYS, &[]);
}

#[test]
#[ignore = "≈ 40 s: deploy/test.sh --full"]
fn golden_only_a_events_over_quic() {
    golden_under("only-a", "events", "", QUIC);
}

#[test]
#[ignore = "≈ 40 s: deploy/test.sh --full"]
fn golden_only_a_rgb_over_quic() {
    golden_under("only-a", "rgb", "", QUIC);
}

#[test]
#[ignore = "≈ 6 min: deploy/test.sh --full"]
fn golden_nominal_3_events_under_delays() {
    golden_under("nominal-3", "events", DELAYS, &[]);
}

#[test]
#[ignore = "≈ 6 min: deploy/test.sh --full"]
fn golden_nominal_3_rgb_under_delays() {
    golden_under("nominal-3", "rgb", DELAYS, &[]);
}

#[test]
#[ignore = "≈ 2 min: deploy/test.sh --full"]
fn golden_nominal_3_events_over_quic() {
    golden_under("nominal-3", "events", "", QUIC);
}

#[test]
#[ignore = "≈ 2 min: deploy/test.sh --full"]
fn golden_nominal_3_rgb_over_quic() {
    golden_under("nominal-3", "rgb", "", QUIC);
}
