//! Every example in `examples/` runs as its README says, and none is left untested: the
//! directory's files are exactly the ones exercised here.

use std::path::PathBuf;
use std::process::Command;

use waggle_tests::{bin, succeed, waggle, workspace_root};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("waggle-example-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn example(name: &str) -> String {
    workspace_root()
        .join("examples")
        .join(name)
        .to_str()
        .expect("UTF-8 path")
        .to_string()
}

/// Runs an example script with this build's `waggle`; its stdout.
fn script(name: &str, args: &[&str]) -> String {
    let out = succeed(
        Command::new("bash")
            .arg(example(name))
            .args(args)
            .env("WAGGLE", bin("waggle"))
            .current_dir(workspace_root()),
        name,
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn every_example_is_exercised() {
    let mut names: Vec<String> = std::fs::read_dir(workspace_root().join("examples"))
        .expect("examples/")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "README.md",
            "custom-case.toml",
            "custom-study.toml",
            "decode-recording.sh",
            "two-hosts.sh"
        ],
        "a new example needs its test here"
    );
}

#[test]
fn the_custom_case_meets_its_expected_outcome() {
    let out = succeed(
        waggle().args([
            "mission",
            &example("custom-case.toml"),
            "--modality",
            "ideal",
        ]),
        "waggle mission examples/custom-case.toml",
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("— PASS"), "{stdout}");
}

#[test]
fn the_custom_study_runs_every_point() {
    let dir = scratch("study");
    succeed(
        waggle()
            .args([
                "study",
                &example("custom-study.toml"),
                "--trials",
                "2",
                "--out",
            ])
            .arg(&dir),
        "waggle study examples/custom-study.toml",
    );
    let study: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("study.json")).expect("study.json"))
            .expect("JSON");
    let _ = std::fs::remove_dir_all(&dir);
    let points = study.as_array().expect("points");
    assert_eq!(points.len(), 3, "{study}");
    for p in points {
        assert_eq!(p["key"], "events.threshold");
        assert_eq!(p["trials"], 2);
    }
}

#[test]
fn the_two_host_example_gives_each_host_only_its_own_credentials() {
    let dir = scratch("two-hosts");
    let stdout = script(
        "two-hosts.sh",
        &[dir.to_str().unwrap(), "quic/10.231.9.1:7447"],
    );
    let secrets = |host: &str| -> Vec<String> {
        let mut names: Vec<String> =
            std::fs::read_dir(dir.join(format!("host-{host}/session.secrets")))
                .expect("a host's credentials")
                .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
                .collect();
        names.sort();
        names
    };
    let (a, b) = (secrets("a"), secrets("b"));
    let _ = std::fs::remove_dir_all(&dir);
    assert!(stdout.contains("on b: waggle up"), "{stdout}");
    assert!(a.iter().any(|n| n.starts_with("sim.")), "{a:?}");
    assert!(!a.iter().any(|n| n.starts_with("camera-")), "{a:?}");
    assert!(b.iter().any(|n| n.starts_with("camera-O1.")), "{b:?}");
    assert!(
        !b.iter()
            .any(|n| n.starts_with("sim.") || n.starts_with("router.key")),
        "{b:?}"
    );
}

#[test]
fn the_decode_example_releases_the_links_payload() {
    let dir = scratch("decode");
    let stdout = script("decode-recording.sh", &[dir.to_str().unwrap()]);
    let _ = std::fs::remove_dir_all(&dir);
    assert!(stdout.contains("payloads [101001]"), "{stdout}");
}
