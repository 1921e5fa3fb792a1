//! `--real-noise`: a real camera's background (the DAVIS346 recording faery's source ships)
//! laid over the trials' event sensor, recorded by digest, the same trials for the same seed;
//! its fitted model in its place; a study file's `real_noise`; bad sources refused naming them.

use std::path::{Path, PathBuf};

use waggle_tests::{succeed, waggle, workspace_root};

fn davis346() -> PathBuf {
    let file = workspace_root().join("third_party/faery/data/davis346.aedat4");
    assert!(
        file.is_file(),
        "{} missing: run `bash deploy/setup.sh`",
        file.display()
    );
    file
}

fn trials(out: &Path, extra: &[&str]) -> std::process::Command {
    trials_of("events", out, extra)
}

fn trials_of(modality: &str, out: &Path, extra: &[&str]) -> std::process::Command {
    let mut cmd = waggle();
    cmd.args(["trials", "--link", "011010", "--observers", "1"])
        .args([
            "--modality",
            modality,
            "--trials",
            "1",
            "--jobs",
            "1",
            "--seed",
            "4",
        ])
        .args(extra)
        .arg("--out")
        .arg(out);
    cmd
}

fn sha256(file: &Path) -> String {
    let out = succeed(
        std::process::Command::new("sha256sum").arg(file),
        "sha256sum",
    );
    String::from_utf8_lossy(&out.stdout)
        .split_whitespace()
        .next()
        .unwrap_or_default()
        .to_owned()
}

fn refused(cmd: &mut std::process::Command, needle: &str) {
    let out = cmd.output().expect("waggle runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success(),
        "accepted; wanted a refusal with {needle:?}"
    );
    assert!(err.contains(needle), "{needle:?} missing from:\n{err}");
}

#[test]
fn a_real_background_drives_trials_reproducibly_and_bad_sources_are_refused() {
    let file = davis346();
    let dir = std::env::temp_dir().join(format!("waggle-real-noise-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let source = file.to_str().unwrap();
    let real = [
        "--real-noise",
        source,
        "--perturb",
        "events.real_noise_copies=50",
    ];
    for run in ["a", "b"] {
        succeed(&mut trials(&dir.join(run), &real), "trials --real-noise");
    }
    let text = |run: &str| std::fs::read(dir.join(run).join("trials.json")).unwrap();
    assert_eq!(text("a"), text("b"), "the same seed, the same trials.json");
    let json: serde_json::Value = serde_json::from_slice(&text("a")).unwrap();
    assert_eq!(
        json["real_noise"]["sha256"],
        sha256(&file).as_str(),
        "{json}"
    );
    assert_eq!(json["real_noise"]["file"], "davis346.aedat4");
    assert_eq!(json["real_noise"]["size_px"], serde_json::json!([346, 260]));
    assert_eq!(json["perturb"]["events.real_noise_copies"], 50.0);

    // The fitted model in place of the events.
    let fitted = [
        "--real-noise",
        source,
        "--perturb",
        "events.real_noise_copies=50",
        "--perturb",
        "events.real_noise_fitted=1",
    ];
    succeed(&mut trials(&dir.join("fitted"), &fitted), "trials fitted");
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("fitted/trials.json")).unwrap()).unwrap();
    assert_eq!(json["perturb"]["events.real_noise_fitted"], 1.0, "{json}");
    // A static stretch instead of isolated events (this recording moves: one copy).
    let stretch = ["--real-noise", source, "--real-noise-static", "0:0.5"];
    succeed(&mut trials(&dir.join("static"), &stretch), "trials static");
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("static/trials.json")).unwrap()).unwrap();
    assert!(
        json["real_noise"]["background"]
            .as_str()
            .is_some_and(|b| b.starts_with("static ")),
        "{json}"
    );

    // A study file's real_noise reaches its points.
    let study = dir.join("study.toml");
    std::fs::write(
        &study,
        format!(
            "name = \"real\"\nmodalities = [\"events\"]\nlink = [\"011010\"]\nobservers = 1\n\
             trials = 1\nseed = 2\ncriterion = \"exact-payloads\"\nreal_noise = {source:?}\n\
             [[vary]]\nkey = \"events.real_noise_copies\"\nlevels = [20.0]\n"
        ),
    )
    .unwrap();
    succeed(
        waggle()
            .arg("study")
            .arg(&study)
            .args(["--jobs", "1", "--out"])
            .arg(dir.join("study")),
        "study with real_noise",
    );
    let point: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("study/events-20/trials.json")).unwrap())
            .unwrap();
    assert_eq!(point["real_noise"]["file"], "davis346.aedat4", "{point}");

    // Refusals, each naming what is wrong.
    let copies_only = ["--perturb", "events.real_noise_copies=3"];
    refused(
        &mut trials(&dir.join("r1"), &copies_only),
        "events.real_noise_copies needs a real-noise source",
    );
    let rgb = ["--real-noise", source];
    refused(
        &mut trials_of("rgb", &dir.join("r2"), &rgb),
        "needs --modality events",
    );
    refused(
        &mut trials(&dir.join("r3"), &["--real-noise", "nopackage/none.raw"]),
        "neither a file nor a fetched recording",
    );
    let junk = dir.join("junk.raw");
    std::fs::write(&junk, b"% just a header line\n\x01\x02").unwrap();
    refused(
        &mut trials(&dir.join("r4"), &["--real-noise", junk.to_str().unwrap()]),
        "junk.raw",
    );
    let loud = [
        "--real-noise",
        source,
        "--perturb",
        "events.real_noise_copies=1000",
    ];
    let mut cmd = trials(&dir.join("r5"), &loud);
    cmd.args([
        "--perturb",
        "events.real_noise_fitted=1",
        "--perturb",
        "events.shot_noise_hz=99",
    ]);
    refused(&mut cmd, "past its");
    let _ = std::fs::remove_dir_all(&dir);
}
