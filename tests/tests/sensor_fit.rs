//! `waggle sensor-fit` on a real camera's recording: it reports the terms, writes a preset file,
//! and that file drives a trial's event sensor as `--sensor-preset FILE`; a missing or malformed
//! preset file is refused naming it.

use waggle_tests::{succeed, waggle, workspace_root};

#[test]
fn a_real_recordings_fit_is_a_preset_that_trials_accept() {
    let file = workspace_root().join("third_party/faery/data/davis346.aedat4");
    assert!(
        file.is_file(),
        "{} missing: run `bash deploy/setup.sh`",
        file.display()
    );
    let dir = std::env::temp_dir().join(format!("waggle-sensor-fit-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let preset = dir.join("davis346.preset");
    let out = succeed(
        waggle()
            .arg("sensor-fit")
            .arg(&file)
            .arg("--out")
            .arg(&preset),
        "waggle sensor-fit",
    );
    let report = String::from_utf8_lossy(&out.stdout);
    for line in [
        "346×260",
        "shot_noise_hz",
        "leak_hz",
        "refractory floor",
        "events per crossing",
        "preset written",
    ] {
        assert!(report.contains(line), "{line:?} missing from:\n{report}");
    }
    let text = std::fs::read_to_string(&preset).unwrap();
    let out = succeed(
        waggle()
            .arg("sensor-fit")
            .arg(&file)
            .args(["--json", "--static", "0:2"]),
        "waggle sensor-fit --json",
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    assert_eq!(json["background"], "static", "{json}");
    assert_eq!(
        [&json["width_px"], &json["height_px"]],
        [346, 260],
        "{json}"
    );
    assert!(
        json["terms"]["events.shot_noise_hz"].as_f64().unwrap() > 0.0,
        "{json}"
    );
    // The DAVIS346's scene moves: its crossings make one to a few events each.
    for key in ["on_events_per_crossing", "off_events_per_crossing"] {
        let per = json[key].as_f64().unwrap_or(0.0);
        assert!((1.0..4.0).contains(&per), "{key} {per}: {json}");
    }
    assert!(text.contains("events.shot_noise_hz = "), "{text}");
    let trials = dir.join("trials");
    let out = succeed(
        waggle()
            .args([
                "trials",
                "--link",
                "011010",
                "--observers",
                "1",
                "--modality",
                "events",
            ])
            .args(["--trials", "1", "--jobs", "1", "--sensor-preset"])
            .arg(&preset)
            .arg("--out")
            .arg(&trials),
        "waggle trials --sensor-preset FILE",
    );
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(said.contains("events.shot_noise_hz="), "{said}");

    let missing = dir.join("nothing.preset");
    let bad = dir.join("bad.preset");
    std::fs::write(&bad, "events.shot_noise_hz 3\n").unwrap();
    for (file, says) in [(&missing, "reading the preset file"), (&bad, "line 1")] {
        let out = waggle()
            .args([
                "trials",
                "--link",
                "011010",
                "--modality",
                "events",
                "--trials",
                "1",
            ])
            .arg("--sensor-preset")
            .arg(file)
            .arg("--out")
            .arg(dir.join("refused"))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{err}");
        assert!(
            err.contains(says) && err.contains(&*file.display().to_string()),
            "{err}"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
