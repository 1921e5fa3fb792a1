//! A study on a real Slurm: Debian's slurm-wlm and munge (installed once), a one-machine cluster
//! started from a generated configuration in a temporary directory (`slurm/cluster.sh`), a small
//! study submitted with `waggle study --slurm --submit` as a 4-task job array with the merge as
//! a dependent job, and the merged result compared byte for byte with the same study run in one
//! process. The daemons are stopped and the directory removed at the end, pass or fail.
//! Needs root (package installation, daemons); `#[ignore]`d: `deploy/test.sh --full`.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

fn script() -> PathBuf {
    waggle_tests::workspace_root().join("tests/tests/slurm/cluster.sh")
}

/// The cluster's directory; dropping it stops the daemons and removes the directory.
struct Cluster {
    dir: PathBuf,
    conf: PathBuf,
}

impl Cluster {
    fn up(dir: &Path) -> Self {
        waggle_tests::succeed(
            Command::new("bash").arg(script()).arg("install"),
            "installing slurm-wlm and munge",
        );
        let mut cluster = Self {
            dir: dir.to_path_buf(),
            conf: PathBuf::new(),
        };
        let out = waggle_tests::succeed(
            Command::new("bash").arg(script()).arg("up").arg(dir),
            "starting munged, slurmctld and slurmd",
        );
        cluster.conf = PathBuf::from(String::from_utf8_lossy(&out.stdout).trim());
        cluster
    }

    fn command(&self, program: &str) -> Command {
        let mut c = Command::new(program);
        c.env("SLURM_CONF", &self.conf);
        c
    }

    /// Logs of the daemons and the jobs, for a failure message.
    fn logs(&self, study: &Path) -> String {
        let mut s = String::new();
        for dir in [self.dir.join("log"), study.join("slurm")] {
            for e in std::fs::read_dir(&dir).into_iter().flatten().flatten() {
                let text = std::fs::read_to_string(e.path()).unwrap_or_default();
                let tail: Vec<&str> = text.lines().rev().take(15).collect();
                s.push_str(&format!("--- {}\n", e.path().display()));
                for l in tail.iter().rev() {
                    s.push_str(l);
                    s.push('\n');
                }
            }
        }
        s
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Command::new("bash")
            .arg(script())
            .arg("down")
            .arg(&self.dir)
            .status();
    }
}

#[test]
#[ignore = "installs and starts Slurm (root), ≈ 3 min: deploy/test.sh --full"]
fn a_study_as_a_slurm_array_merges_to_the_single_run_byte_for_byte() {
    let root = std::env::temp_dir().join(format!("waggle-slurm-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&root).unwrap();
    let cluster = Cluster::up(&root.join("cluster"));
    let file = root.join("slurm.toml");
    std::fs::write(&file, waggle_tests::two_condition_study("slurm", 13)).unwrap();
    let study = root.join("study");
    let submitted = waggle_tests::succeed(
        waggle_tests::waggle()
            .env("SLURM_CONF", &cluster.conf)
            .arg("study")
            .arg(&file)
            .args([
                "--slurm",
                "--submit",
                "--shard-count",
                "4",
                "--cpus-per-task",
                "1",
            ])
            .args([
                "--mem",
                "2G",
                "--time",
                "00:30:00",
                "--partition",
                "waggle",
                "--out",
            ])
            .arg(&study),
        "waggle study --slurm --submit",
    );
    let said = String::from_utf8_lossy(&submitted.stdout).into_owned();
    assert!(said.contains("(4 tasks), merge job"), "{said}");

    // Meanwhile, the same study in one process.
    let single = root.join("single");
    waggle_tests::succeed(
        waggle_tests::waggle()
            .arg("study")
            .arg(&file)
            .args(["--jobs", "1", "--out"])
            .arg(&single),
        "the study in one process",
    );

    let started = Instant::now();
    loop {
        let q = cluster.command("squeue").args(["-h"]).output().unwrap();
        if q.status.success() && q.stdout.is_empty() {
            break;
        }
        assert!(
            started.elapsed() < Duration::from_secs(1200),
            "the jobs did not finish in 20 min:\n{}",
            cluster.logs(&study)
        );
        std::thread::sleep(Duration::from_secs(2));
    }
    let merged = study.join("merged");
    assert!(
        merged.join("report.md").exists(),
        "no merged report:\n{}",
        cluster.logs(&study)
    );
    for k in 1..=4 {
        assert!(study.join(format!("shard-{k}-of-4/run.json")).exists());
    }
    let points: serde_json::Value =
        serde_json::from_slice(&std::fs::read(single.join("study.json")).unwrap()).unwrap();
    let mut files: Vec<String> = [
        "study.json",
        "report.md",
        "provenance.json",
        "success-rgb.read_noise_grey.svg",
        "success-events.shot_noise_hz.svg",
    ]
    .map(String::from)
    .to_vec();
    for p in points.as_array().unwrap() {
        files.push(format!("{}/trials.json", p["dir"].as_str().unwrap()));
    }
    assert_eq!(files.len(), 5 + 6);
    for f in &files {
        let (a, b) = (
            std::fs::read(single.join(f)).unwrap(),
            std::fs::read(merged.join(f)).unwrap_or_else(|e| panic!("merged {f}: {e}")),
        );
        assert!(
            a == b,
            "{f} differs between the single run and the Slurm merge"
        );
    }
    let cost: serde_json::Value =
        serde_json::from_slice(&std::fs::read(merged.join("cost.json")).unwrap()).unwrap();
    assert_eq!(cost["runs"], 4, "{cost}");
    assert_eq!(cost["trials_run"], 12, "{cost}");
    drop(cluster);
    assert!(
        !root.join("cluster").exists(),
        "the cluster's directory is removed"
    );
    let _ = std::fs::remove_dir_all(&root);
}
