//! `waggle decode --events FILE.raw`: an event recording decoded by one observer's receiver.
//!
//! Round trip: `waggle link --events-raw` writes each observer's events as Prophesee EVT 3.0;
//! decoding the file from the same viewpoint gives exactly the live link's tokens, frames and
//! payloads (a viewpoint and payload no other test uses), with the frame check it was flown
//! with. Bad input is refused naming it. A whole mission's cameras are written the same way
//! (`waggle mission --events-raw`), and its recording decodes to the messages it released.

mod common;
use common::{link, payloads};

fn decode(args: &[&str]) -> serde_json::Value {
    let out = waggle_tests::succeed(
        waggle_tests::waggle()
            .arg("decode")
            .args(args)
            .arg("--json"),
        &format!("waggle decode {args:?}"),
    );
    serde_json::from_slice(&out.stdout).expect("JSON output")
}

fn round_trip(check: &str, extra: &[&str]) {
    let dir = std::env::temp_dir().join(format!(
        "waggle-decode-{}-{}",
        std::process::id(),
        extra.len()
    ));
    let dir_s = dir.to_str().unwrap().to_owned();
    // `=`: the value starts with a minus sign.
    let viewpoint = "--viewpoint=-25,8,1.7";
    let mut args = vec![
        "--modality",
        "events",
        viewpoint,
        "--payload",
        "110010",
        "--events-raw",
        &dir_s,
        "--frame-check",
        check,
    ];
    args.extend_from_slice(extra);
    let live = link(&args);
    let file = dir.join("O1.raw");
    let file_s = file.to_str().unwrap();
    let decoded = decode(&["--events", file_s, viewpoint, "--frame-check", check]);
    // Read as the paper's frame, a checked frame's first check bit stands where END should.
    let unchecked = (check != "none").then(|| decode(&["--events", file_s, viewpoint]));
    let _ = std::fs::remove_dir_all(&dir);
    if let Some(u) = unchecked {
        assert_eq!(u["decoded"]["payloads"], serde_json::json!([]), "{u}");
        assert_eq!(u["decoded"]["tokens"], decoded["decoded"]["tokens"]);
    }
    assert_eq!(payloads(&live, "O1"), ["110010"], "{live}");
    assert_eq!(
        decoded["decoded"]["payloads"],
        live["observers"]["O1"]["payloads"]
    );
    assert_eq!(
        decoded["decoded"]["frames"],
        live["observers"]["O1"]["frames"]
    );
    assert_eq!(
        decoded["decoded"]["tokens"],
        live["observers"]["O1"]["tokens"]
    );
    assert!(decoded["events"].as_u64().unwrap() > 100_000, "{decoded}");
}

#[test]
fn a_written_checked_recording_decodes_exactly_as_the_live_link() {
    round_trip("crc3", &[]);
}

#[test]
#[ignore = "long: a noisy sensor (≈ 25 s); runs with deploy/test.sh --full"]
fn a_noisy_written_recording_decodes_exactly_as_the_live_link() {
    round_trip("none", &["--sensor-preset", "v2e-default", "--seed", "3"]);
}

/// `waggle decode --events FILE --observer OBSERVER`'s error output; the command must fail.
fn refusal(file: &std::path::Path, observer: &str) -> String {
    let out = waggle_tests::waggle()
        .args([
            "decode",
            "--events",
            file.to_str().unwrap(),
            "--observer",
            observer,
        ])
        .output()
        .unwrap();
    assert!(
        !out.status.success(),
        "decode of {} succeeded",
        file.display()
    );
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn bad_recordings_and_viewpoints_are_refused_naming_them() {
    let dir = std::env::temp_dir().join(format!("waggle-decode-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("cut.raw");
    std::fs::write(&file, b"% evt 3.0\n% geometry 640x480\n% end\n\x01\x80\x05").unwrap();
    let err = refusal(&file, "O1");
    assert!(err.contains("byte 37"), "{err}");
    // Another sensor size is remapped into the reference camera, not refused.
    std::fs::write(&file, b"% evt 3.0\n% geometry 320x240\n% end\n").unwrap();
    let small = decode(&["--events", file.to_str().unwrap(), "--observer", "O1"]);
    assert_eq!(small["remapped"], true, "{small}");
    assert_eq!(small["width_px"], 320);
    let err = refusal(&file, "O9");
    assert!(err.contains("O9"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_missions_written_events_decode_to_the_messages_it_released() {
    let dir = std::env::temp_dir().join(format!("waggle-decode-mission-{}", std::process::id()));
    let dir_s = dir.to_str().unwrap();
    let out = waggle_tests::succeed(
        waggle_tests::waggle().args([
            "mission",
            "one-observer",
            "--modality",
            "events",
            "--events-raw",
            dir_s,
            "--json",
        ]),
        "waggle mission one-observer --events-raw",
    );
    let live: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON output");
    let file = dir.join("O1.raw");
    let decoded = decode(&["--events", file.to_str().unwrap(), "--observer", "O1"]);
    let _ = std::fs::remove_dir_all(&dir);
    let released = &live["observers"]["O1"]["payloads"];
    assert_eq!(released.as_array().map(Vec::len), Some(4), "{live}");
    assert_eq!(&decoded["decoded"]["payloads"], released, "{decoded}");
    // Only event cameras have events to write.
    let out = waggle_tests::waggle()
        .args([
            "mission",
            "one-observer",
            "--modality",
            "rgb",
            "--events-raw",
            dir_s,
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--events-raw") && err.contains("Rgb"), "{err}");
    assert!(!dir.exists(), "a refused mission wrote {}", dir.display());
}
