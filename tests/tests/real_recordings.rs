//! `waggle decode --events` on real cameras' recordings (the faery source package's, unpacked by
//! `deploy/setup.sh` into `third_party/faery/`): each is read, every event reaches the receiver,
//! and no dance is found in a scene with none; a recording cut short is refused naming the file
//! and the byte.

use std::path::{Path, PathBuf};

use serde_json::Value;
use waggle_tests::{succeed, waggle, workspace_root};

const VIEWPOINT: &str = "--observer=O2";

fn real(name: &str) -> PathBuf {
    let path = workspace_root().join("third_party/faery/data").join(name);
    assert!(
        path.is_file(),
        "{} missing: run `bash deploy/setup.sh`",
        path.display()
    );
    path
}

fn decode(file: &Path) -> Value {
    let out = succeed(
        waggle()
            .args(["decode", "--events"])
            .arg(file)
            .args([VIEWPOINT, "--json"]),
        &format!("waggle decode --events {}", file.display()),
    );
    serde_json::from_slice(&out.stdout).expect("JSON output")
}

#[test]
fn every_real_recording_decodes_with_every_event_and_no_payload() {
    // (file, format, events as the readers count them, checked against faery's digests in
    // libs/event-formats/tests/real_files.rs)
    for (name, format, size) in [
        ("evt3.raw", "evt3", [1280, 720]),
        ("evt2.raw", "evt2", [640, 480]),
        ("gen4.dat", "dat", [1280, 720]),
        ("davis346.aedat4", "aedat4 (LZ4)", [346, 260]),
    ] {
        let path = real(name);
        let bytes = std::fs::read(&path).unwrap();
        let events = match format {
            "evt3" => event_formats::evt3::read(&bytes).unwrap().events.len(),
            "evt2" => event_formats::evt2::read(&bytes).unwrap().events.len(),
            "dat" => event_formats::dat::read(&bytes).unwrap().events.len(),
            _ => event_formats::aedat4::read(&bytes).unwrap().events.len(),
        };
        let decoded = decode(&path);
        assert_eq!(decoded["format"], format, "{name}: {decoded}");
        assert_eq!(decoded["events"], events as u64, "{name}: {decoded}");
        if name != "evt2.raw" {
            // evt2.raw's header states no geometry; the others' is read from the file.
            let stated = [&decoded["width_px"], &decoded["height_px"]];
            assert_eq!(stated, [size[0], size[1]], "{name}: {decoded}");
        }
        assert_eq!(
            decoded["decoded"]["payloads"],
            serde_json::json!([]),
            "{name}"
        );
    }
}

#[test]
fn real_recordings_cut_short_are_refused_naming_the_byte() {
    let dir = std::env::temp_dir().join(format!("waggle-real-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for name in ["evt3.raw", "evt2.raw", "gen4.dat", "davis346.aedat4"] {
        let bytes = std::fs::read(real(name)).unwrap();
        // Prophesee files lose their last byte (a word or an event cut short); the AEDAT4 file
        // is cut inside a compressed packet (its last bytes are an index the reader skips).
        let keep = if name.ends_with("aedat4") {
            bytes.len() / 3 * 2 + 1
        } else {
            bytes.len() - 1
        };
        let cut = dir.join(format!("cut-{name}"));
        std::fs::write(&cut, &bytes[..keep]).unwrap();
        let out = waggle()
            .args(["decode", "--events"])
            .arg(&cut)
            .arg(VIEWPOINT)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{name} cut short decoded: {err}");
        assert!(
            err.contains(&format!("cut-{name}")) && err.contains("byte "),
            "{name}: {err}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
