//! `waggle compose` + `waggle up` on one host is `waggle run`: the same nodes with the same
//! arguments give the golden run's `observers.json` and sensor digests (which `frozen.rs` checks
//! `waggle run` against); bad compose files, hosts and router invocations are refused with an
//! error naming what is wrong, before anything starts.

use std::path::PathBuf;
use std::process::Stdio;

use deploy::run_dir::RunSummary;
use waggle_tests::{succeed, waggle, waggle_with_nodes};

mod golden_runs;
use golden_runs::{golden_entry, sha256_hex};

fn fresh_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("waggle-compose-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create the test directory");
    dir
}

fn compose(dir: &std::path::Path, args: &[&str]) -> PathBuf {
    let file = dir.join("session.toml");
    succeed(
        waggle().arg("compose").args(args).arg("--out").arg(&file),
        &format!("waggle compose {args:?}"),
    );
    file
}

#[test]
fn compose_then_up_on_one_host_equals_run() {
    let dir = fresh_dir("equal");
    let file = compose(&dir, &["only-a", "--modality", "rgb"]);
    let text = std::fs::read_to_string(&file).unwrap();
    assert!(text.contains("[[node]]") && text.contains("role = \"camera-O3\""));
    let secrets = dir.join("session.secrets");
    let mode = std::os::unix::fs::PermissionsExt::mode(
        &std::fs::metadata(&secrets).unwrap().permissions(),
    );
    assert_eq!(mode & 0o777, 0o700, "the credentials directory is private");

    let run = dir.join("run");
    let out = waggle_with_nodes()
        .args(["up", "--quiet", "--out"])
        .arg(&run)
        .arg(&file)
        .stdin(Stdio::null())
        .output()
        .expect("run waggle up");
    assert!(
        out.status.success(),
        "waggle up: {}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let want = golden_entry("only-a", "rgb");
    let observers = std::fs::read(run.join("observers.json")).unwrap();
    assert_eq!(
        sha256_hex(&observers),
        want["observers_sha256"].as_str().unwrap(),
        "compose + up differs from waggle run's golden observers.json ({})",
        run.display()
    );
    let summary: RunSummary =
        serde_json::from_slice(&std::fs::read(run.join("summary.json")).unwrap()).unwrap();
    for (o, digest) in want["sensor_digests"].as_table().unwrap() {
        assert_eq!(
            summary.sensor_digests.get(o).map(String::as_str),
            digest.as_str(),
            "{o}"
        );
    }
    assert!(
        run.join("session.mcap").is_file(),
        "the recorder wrote the session"
    );
    // Every process of the one host ran under the session's credentials, then they were kept.
    assert!(secrets.join("dictionary").is_file());
}

/// Runs `waggle ARGS` and returns its stderr, asserting it failed.
fn refused(args: &[&str]) -> String {
    let out = waggle().args(args).output().expect("run waggle");
    assert!(!out.status.success(), "waggle {args:?} succeeded");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Runs `waggle compose ARGS… --out FILE` in a fresh directory named `name` and returns its
/// stderr, asserting it failed.
fn compose_refused(name: &str, args: &[&str]) -> String {
    // Its own directory: the caller's may hold a good session.
    let file = fresh_dir(&format!("{name}-refusal")).join("s.toml");
    let mut all = vec!["compose"];
    all.extend_from_slice(args);
    all.extend(["--out", file.to_str().unwrap()]);
    refused(&all)
}

#[test]
fn plain_tcp_beyond_loopback_is_refused_unless_asked_for() {
    let dir = fresh_dir("plain-tcp");
    let e = compose_refused(
        "plain-tcp",
        &[
            "one-observer",
            "--router",
            "tcp/192.0.2.1:7447",
            "--place",
            "camera-*=b",
        ],
    );
    assert!(e.contains("--plain-tcp") && e.contains("quic/"), "{e}");
    compose(
        &dir,
        &[
            "one-observer",
            "--place",
            "camera-*=b",
            "--router",
            "quic/192.0.2.1:7447",
        ],
    );
}

#[test]
fn bad_sessions_hosts_and_routers_are_refused_naming_the_input() {
    let dir = fresh_dir("refused");
    let e = compose_refused("refused", &["one-observer", "--place", "camera-O7=b"]);
    assert!(e.contains("camera-O7"), "{e}");
    let e = compose_refused("refused", &["one-observer", "--place", "camera-*"]);
    assert!(e.contains("ROLE=HOST"), "{e}");
    // Two hosts need a router address the other host can dial.
    let e = compose_refused("refused", &["one-observer", "--place", "camera-*=b"]);
    assert!(e.contains("reach"), "{e}");
    let e = compose_refused(
        "refused",
        &[
            "one-observer",
            "--no-auth",
            "--router",
            "tcp/192.0.2.1:7447",
            "--place",
            "camera-*=b",
        ],
    );
    assert!(e.contains("auth = false"), "{e}");

    let good = compose(
        &dir,
        &[
            "one-observer",
            "--place",
            "camera-*=b",
            "--router",
            "tcp/192.0.2.1:7447",
            "--plain-tcp",
        ],
    );
    let good_s = good.to_str().unwrap();
    let e = refused(&["up", good_s, "--host", "z"]);
    assert!(e.contains("\"z\"") && e.contains("local"), "{e}");
    // A bundle is for a host of the session, into a new directory.
    let e = refused(&[
        "bundle",
        good_s,
        "--host",
        "z",
        "--out",
        dir.join("bz").to_str().unwrap(),
    ]);
    assert!(e.contains("\"z\"") && e.contains("local"), "{e}");
    assert!(!dir.join("bz").exists(), "a refused bundle leaves nothing");
    let e = refused(&[
        "bundle",
        good_s,
        "--host",
        "b",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(e.contains("exists already"), "{e}");
    // An unknown key, then a forged node.
    let text = std::fs::read_to_string(&good).unwrap();
    std::fs::write(
        &good,
        text.replacen("version = 1", "version = 1\ncolour = 2", 1),
    )
    .unwrap();
    let e = refused(&["up", good_s]);
    assert!(e.contains("colour"), "{e}");
    std::fs::write(
        &good,
        text.replacen("role = \"performer\"", "role = \"intruder\"", 1),
    )
    .unwrap();
    let e = refused(&["up", good_s]);
    assert!(e.contains("intruder"), "{e}");
    // Credentials readable by others are refused, like ssh keys.
    std::fs::write(&good, &text).unwrap();
    let secrets = dir.join("session.secrets");
    std::fs::set_permissions(
        &secrets,
        std::os::unix::fs::PermissionsExt::from_mode(0o755),
    )
    .unwrap();
    let e = refused(&["up", good_s, "--host", "b"]);
    assert!(e.contains("chmod"), "{e}");

    let e = refused(&["router", "--listen", "tcp/127.0.0.1:0"]);
    assert!(e.contains("--compose"), "{e}");
    let e = refused(&[
        "router",
        "--no-auth",
        "--session",
        "s",
        "--listen",
        "tcp/0.0.0.0:7447",
    ]);
    assert!(e.contains("open the session to the network"), "{e}");
}

/// An institution's CA, made with `openssl` as its administrator would: `waggle compose
/// --ca-cert --ca-key` issues the session's certificates with it (the session's `ca.pem` is
/// its certificate, its key is not copied), and a CA key others may read is refused.
#[test]
fn an_institutions_ca_signs_the_sessions_certificates() {
    let dir = fresh_dir("institution-ca");
    let (cert, key) = (dir.join("inst-ca.crt"), dir.join("inst-ca.key"));
    succeed(
        std::process::Command::new("openssl")
            .args(["req", "-x509", "-newkey", "ec", "-pkeyopt"])
            .args(["ec_paramgen_curve:P-256", "-nodes", "-days", "30"])
            .args(["-subj", "/CN=Example robotics lab CA", "-keyout"])
            .arg(&key)
            .arg("-out")
            .arg(&cert),
        "openssl req (an institution's CA)",
    );
    std::fs::set_permissions(&key, std::os::unix::fs::PermissionsExt::from_mode(0o600)).unwrap();
    let (c, k) = (cert.to_str().unwrap(), key.to_str().unwrap());
    let file = compose(
        &dir,
        &[
            "one-observer",
            "--place",
            "*-O1=b",
            "--router",
            "quic/192.0.2.1:7447",
            "--site",
            "b=quic/192.0.2.2:7447",
            "--ca-cert",
            c,
            "--ca-key",
            k,
        ],
    );
    let secrets = file.with_extension("secrets");
    assert_eq!(
        std::fs::read_to_string(secrets.join("ca.pem")).unwrap(),
        std::fs::read_to_string(&cert).unwrap()
    );
    let key_text = std::fs::read_to_string(&key).unwrap();
    for entry in std::fs::read_dir(&secrets).unwrap() {
        let held = std::fs::read_to_string(entry.unwrap().path()).unwrap();
        assert_ne!(held, key_text, "the CA's key was copied");
    }
    // openssl verifies a process's certificate against the institution's CA.
    succeed(
        std::process::Command::new("openssl")
            .args(["verify", "-CAfile"])
            .arg(&cert)
            .arg(secrets.join("camera-O1.cert.pem")),
        "openssl verify",
    );
    let text = std::fs::read_to_string(&file).unwrap();
    assert!(
        text.contains("[[site]]") && text.contains("quic/192.0.2.2:7447"),
        "{text}"
    );

    let e = compose_refused("ca-alone", &["one-observer", "--ca-cert", c]);
    assert!(e.contains("--ca-key"), "{e}");
    std::fs::set_permissions(&key, std::os::unix::fs::PermissionsExt::from_mode(0o644)).unwrap();
    let e = compose_refused(
        "ca-open-key",
        &["one-observer", "--ca-cert", c, "--ca-key", k],
    );
    assert!(
        e.contains("readable by other users") && e.contains("inst-ca.key"),
        "{e}"
    );
}
