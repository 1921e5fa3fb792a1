//! `waggle` is the one command, but the lab commands (the ones that fly the simulator) run in
//! `waggle-lab`, so the operations start without MuJoCo:
//!
//! - the built `waggle` loads no `libmujoco` (`ldd`), while `waggle-lab` does;
//! - both binaries parse with the one definition in `commands`: `waggle --help`, every
//!   `waggle CMD --help` and `waggle help CMD` are `waggle-lab`'s, byte for byte;
//! - a usage error is the parser's (exit 2); a lab command's own errors and exit code pass
//!   through; `waggle-lab` refuses a launcher command, naming `waggle`;
//! - without `waggle-lab` beside it, a lab command fails naming the missing file, and the
//!   operations still run.
//!
//! `tests/tests/layering.rs` checks the same split in the crate graph.

use std::path::Path;
use std::process::Command;

use waggle_tests::{bin, succeed, waggle};

fn ldd(path: &Path) -> Option<String> {
    let out = Command::new("ldd").arg(path).output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).into_owned())
}

#[test]
fn waggle_does_not_link_mujoco_and_waggle_lab_does() {
    let (Some(waggle), Some(lab)) = (ldd(&bin("waggle")), ldd(&bin("waggle-lab"))) else {
        eprintln!("no ldd on this machine: skipped (the crate graph is checked in layering.rs)");
        return;
    };
    assert!(
        !waggle.to_lowercase().contains("mujoco"),
        "waggle links MuJoCo:\n{waggle}"
    );
    assert!(
        lab.contains("libmujoco"),
        "waggle-lab does not link MuJoCo (is ldd's output what this test expects?):\n{lab}"
    );
}

/// Every command's name, from the one definition both binaries parse with.
fn command_names() -> Vec<String> {
    commands::command()
        .get_subcommands()
        .map(|c| c.get_name().to_owned())
        .filter(|n| n != "help")
        .collect()
}

#[test]
fn both_binaries_parse_with_one_definition() {
    let text = |out: std::process::Output| String::from_utf8(out.stdout).expect("UTF-8 help");
    let waggle_help = text(succeed(waggle().arg("--help"), "waggle --help"));
    let lab_help = text(succeed(
        Command::new(bin("waggle-lab")).arg("--help"),
        "waggle-lab --help",
    ));
    assert_eq!(
        waggle_help, lab_help,
        "waggle --help and waggle-lab --help differ"
    );
    let names = command_names();
    assert!(names.len() >= 20, "{names:?}");
    for command in &names {
        assert!(
            waggle_help.contains(&format!("\n  {command} ")),
            "waggle --help does not list {command}:\n{waggle_help}"
        );
        let ours = text(succeed(
            waggle().args([command, "--help"]),
            &format!("waggle {command} --help"),
        ));
        let lab = text(succeed(
            Command::new(bin("waggle-lab")).args([command, "--help"]),
            &format!("waggle-lab {command} --help"),
        ));
        assert_eq!(ours, lab, "waggle {command} --help");
        assert!(ours.contains(&format!("Usage: waggle {command}")), "{ours}");
        let via_help = text(succeed(
            waggle().args(["help", command]),
            &format!("waggle help {command}"),
        ));
        assert_eq!(via_help, ours, "waggle help {command}");
    }
    // A usage error is the parser's, exit 2, whichever binary would run the command.
    for command in ["mission", "run"] {
        let bad = waggle()
            .args([command, "--no-such-option"])
            .output()
            .expect("run waggle");
        assert_eq!(bad.status.code(), Some(2), "clap's usage error exits 2");
        let stderr = String::from_utf8_lossy(&bad.stderr);
        assert!(stderr.contains("--no-such-option"), "{stderr}");
    }
    // A lab command's own error and exit code come back unchanged.
    let missing = std::env::temp_dir().join("waggle-no-such-recording.raw");
    let out = waggle()
        .args(["decode", "--observer", "O1", "--events"])
        .arg(&missing)
        .output()
        .expect("run waggle decode");
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("waggle-no-such-recording.raw"), "{stderr}");
    // waggle-lab refuses a launcher command, naming the binary that runs it.
    let out = Command::new(bin("waggle-lab"))
        .args(["payload", "decode", "011010"])
        .output()
        .expect("run waggle-lab payload");
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("runs in the waggle binary"), "{stderr}");
}

#[test]
fn without_waggle_lab_the_operations_still_run_and_lab_commands_name_it() {
    let dir = std::env::temp_dir().join(format!("waggle-lab-split-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let alone = dir.join("waggle");
    // A hard link when the temporary directory shares the build's file system, else a copy.
    if std::fs::hard_link(bin("waggle"), &alone).is_err() {
        std::fs::copy(bin("waggle"), &alone).expect("copy waggle");
    }
    let payload = succeed(
        Command::new(&alone).args(["payload", "decode", "011010"]),
        "waggle payload without waggle-lab",
    );
    assert!(!payload.stdout.is_empty());
    succeed(
        Command::new(&alone).args(["up", "--help"]),
        "waggle up --help without waggle-lab",
    );
    succeed(
        Command::new(&alone).args(["trials", "--help"]),
        "waggle trials --help without waggle-lab (one parser, in waggle)",
    );
    let lab = Command::new(&alone)
        .args([
            "trials",
            "--link",
            "011010",
            "--modality",
            "events",
            "--out",
        ])
        .arg(dir.join("out"))
        .output()
        .expect("run waggle trials");
    let _ = std::fs::remove_dir_all(&dir);
    assert!(
        !lab.status.success(),
        "waggle trials ran without waggle-lab"
    );
    let stderr = String::from_utf8_lossy(&lab.stderr);
    assert!(
        stderr.contains(&dir.join("waggle-lab").display().to_string()),
        "the error names the missing waggle-lab: {stderr}"
    );
}
