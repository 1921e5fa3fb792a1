//! `waggle` is the one command, but the lab commands (the ones that fly the simulator) run in
//! `waggle-lab`, so the operations start without MuJoCo (issue 29):
//!
//! - the built `waggle` loads no `libmujoco` (`ldd`), while `waggle-lab` does;
//! - `waggle --help` lists every lab command with the one-line description `waggle-lab` gives
//!   it, and `waggle LABCMD --help` is `waggle-lab`'s help, byte for byte;
//! - a lab command's exit code and errors pass through;
//! - without `waggle-lab` beside it, a lab command fails naming the missing file, and the
//!   operations still run.
//!
//! `tests/tests/layering.rs` checks the same split in the crate graph.

use std::path::Path;
use std::process::Command;

use deploy::cli::lab::LAB_COMMANDS;
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

/// The description `help` gives `command` in a `--help` command list.
fn listed<'a>(help: &'a str, command: &str) -> Option<&'a str> {
    help.lines().find_map(|l| {
        let rest = l.trim_start().strip_prefix(command)?;
        rest.starts_with(' ').then(|| rest.trim())
    })
}

#[test]
fn waggle_lists_and_forwards_every_lab_command() {
    let text = |out: std::process::Output| String::from_utf8(out.stdout).expect("UTF-8 help");
    let waggle_help = text(succeed(waggle().arg("--help"), "waggle --help"));
    let lab_help = text(succeed(
        Command::new(bin("waggle-lab")).arg("--help"),
        "waggle-lab --help",
    ));
    for command in LAB_COMMANDS {
        let ours = listed(&waggle_help, command)
            .unwrap_or_else(|| panic!("waggle --help does not list {command}:\n{waggle_help}"));
        assert_eq!(
            Some(ours),
            listed(&lab_help, command),
            "waggle --help and waggle-lab --help describe {command} differently"
        );
        let forwarded = text(succeed(
            waggle().args([command, "--help"]),
            &format!("waggle {command} --help"),
        ));
        let direct = text(succeed(
            Command::new(bin("waggle-lab")).args([command, "--help"]),
            &format!("waggle-lab {command} --help"),
        ));
        assert_eq!(forwarded, direct, "waggle {command} --help");
        assert!(
            forwarded.contains(&format!("Usage: waggle {command}")),
            "{forwarded}"
        );
        let via_help = text(succeed(
            waggle().args(["help", command]),
            &format!("waggle help {command}"),
        ));
        assert_eq!(via_help, direct, "waggle help {command}");
    }
    // waggle-lab serves nothing else.
    for line in lab_help
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
    {
        let Some(name) = line.split_whitespace().next() else {
            break;
        };
        assert!(
            name == "help" || LAB_COMMANDS.contains(&name),
            "waggle-lab serves {name}, which waggle does not forward"
        );
    }
    // A lab command's usage error and exit code come back unchanged.
    let bad = waggle()
        .args(["mission", "--no-such-option"])
        .output()
        .expect("run waggle mission");
    assert_eq!(bad.status.code(), Some(2), "clap's usage error exits 2");
    let stderr = String::from_utf8_lossy(&bad.stderr);
    assert!(stderr.contains("--no-such-option"), "{stderr}");
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
    let lab = Command::new(&alone)
        .args(["trials", "--help"])
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
