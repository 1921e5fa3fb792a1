//! `waggle decode --events` on recordings of other formats and other cameras: the same events
//! as an AEDAT4 file written by iniVation's own `dv-processing` and by Waggle's writer, and as
//! seen by a camera of another resolution with lens distortion (remapped through its
//! calibration file), decode to exactly the live link's payloads.
//!
//! One `waggle link --events-raw` (a payload and viewpoint no other test uses) gives the events;
//! each test rewrites them into its format or camera and decodes the file from the same
//! viewpoint. `tools/aedat4/aedat4_check.py` runs in the venv `deploy/setup.sh` makes.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

use event_camera::Event;
use event_formats::{aedat4, dat, evt2, evt3};
use serde_json::Value;
use waggle_tests::{succeed, venv_python, waggle, workspace_root};

const VIEWPOINT: &str = "--viewpoint=18,-6,1.5";
const PAYLOAD: &str = "101101";

fn scratch() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("waggle-ingest-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The live link's output and its O1 events, once for every test.
fn live() -> &'static (Value, Vec<Event>) {
    static LIVE: OnceLock<(Value, Vec<Event>)> = OnceLock::new();
    LIVE.get_or_init(|| {
        let dir = scratch().join("raw");
        let out = common::link(&[
            "--modality",
            "events",
            VIEWPOINT,
            "--payload",
            PAYLOAD,
            "--events-raw",
            dir.to_str().unwrap(),
        ]);
        assert_eq!(common::payloads(&out, "O1"), [PAYLOAD], "{out}");
        let raw = evt3::read(&std::fs::read(dir.join("O1.raw")).unwrap()).unwrap();
        assert!(raw.events.len() > 100_000, "{} events", raw.events.len());
        (out, raw.events)
    })
}

/// `waggle decode --events FILE VIEWPOINT ARGS… --json`.
fn decode(file: &Path, args: &[&str]) -> Value {
    let out = succeed(
        waggle()
            .args(["decode", "--events"])
            .arg(file)
            .arg(VIEWPOINT)
            .args(args)
            .arg("--json"),
        &format!("waggle decode --events {} {args:?}", file.display()),
    );
    serde_json::from_slice(&out.stdout).expect("JSON output")
}

fn assert_decodes_as_live(decoded: &Value, exact_tokens: bool) {
    let live = &live().0["observers"]["O1"];
    assert_eq!(
        decoded["decoded"]["payloads"], live["payloads"],
        "{decoded}"
    );
    if exact_tokens {
        assert_eq!(decoded["decoded"]["tokens"], live["tokens"]);
        assert_eq!(decoded["decoded"]["frames"], live["frames"]);
    }
}

#[test]
fn an_aedat4_file_from_dv_processing_decodes_as_the_live_link() {
    let (_, events) = live();
    let dir = scratch().join("dv");
    std::fs::create_dir_all(&dir).unwrap();
    // aedat4_check.py's input: 16-byte records (i64 t_us, i16 x, i16 y, u8 polarity, padding).
    let mut records = Vec::with_capacity(events.len() * 16);
    for e in events {
        records.extend_from_slice(&((e.t_ns / 1000) as i64).to_le_bytes());
        records.extend_from_slice(&(e.x as i16).to_le_bytes());
        records.extend_from_slice(&(e.y as i16).to_le_bytes());
        records.push(u8::from(e.polarity == proto::Polarity::On));
        records.extend_from_slice(&[0; 3]);
    }
    let (bin, file) = (dir.join("events.bin"), dir.join("O1.aedat4"));
    std::fs::write(&bin, records).unwrap();
    succeed(
        Command::new(venv_python())
            .arg(workspace_root().join("tools/aedat4/aedat4_check.py"))
            .args(["write"])
            .args([&bin, &file])
            .args(["640", "480", "LZ4"]),
        "aedat4_check.py write (dv-processing)",
    );
    let decoded = decode(&file, &[]);
    assert_eq!(decoded["format"], "aedat4 (LZ4)");
    assert_eq!(decoded["events"], events.len() as u64);
    // The file keeps microseconds, as EVT 3.0 does: the same packets, the same tokens.
    assert_decodes_as_live(&decoded, true);
}

#[test]
fn waggles_own_aedat4_file_decodes_as_the_live_link() {
    let (_, events) = live();
    let file = scratch().join("own.aedat4");
    let mut bytes = Vec::new();
    aedat4::write(
        &mut bytes,
        640,
        480,
        events,
        &aedat4::WriteOptions {
            compression: aedat4::Compression::Zstd,
            events_per_packet: 5000,
        },
    )
    .unwrap();
    std::fs::write(&file, bytes).unwrap();
    // Named explicitly, and told from the file.
    assert_decodes_as_live(&decode(&file, &["--format", "aedat4"]), true);
    assert_eq!(decode(&file, &[])["format"], "aedat4 (ZSTD)");
}

/// A 1280×960 camera with twice the reference's focal length, its principal point off centre
/// and a barrel lens, as a ROS `camera_info` file.
const CAMERA_INFO: &str = "image_width: 1280\nimage_height: 960\ncamera_name: test\n\
camera_matrix:\n  rows: 3\n  cols: 3\n  data: [FX, 0, 652.0, 0, FY, 471.0, 0, 0, 1]\n\
distortion_model: plumb_bob\ndistortion_coefficients:\n  rows: 1\n  cols: 5\n  \
data: [-0.12, 0.03, 0.0005, -0.0004, 0.0]\n";

/// Where the reference camera's pixel `(x, y)` is seen by [`CAMERA_INFO`]'s camera.
fn through_the_lens(x: u16, y: u16, f: f64) -> (u16, u16) {
    let (k1, k2, p1, p2) = (-0.12, 0.03, 0.0005, -0.0004);
    let (xn, yn) = ((f64::from(x) - 319.5) / f, (f64::from(y) - 239.5) / f);
    let r2 = xn * xn + yn * yn;
    let radial = 1.0 + k1 * r2 + k2 * r2 * r2;
    let xd = xn * radial + 2.0 * p1 * xn * yn + p2 * (r2 + 2.0 * xn * xn);
    let yd = yn * radial + p1 * (r2 + 2.0 * yn * yn) + 2.0 * p2 * xn * yn;
    (
        (2.0 * f * xd + 652.0).round() as u16,
        (2.0 * f * yd + 471.0).round() as u16,
    )
}

#[test]
fn another_camera_with_its_calibration_decodes_as_the_live_link() {
    let (_, events) = live();
    let dir = scratch().join("calibrated");
    std::fs::create_dir_all(&dir).unwrap();
    // The reference camera's focal length (640×480, 45° vertical field).
    let f = 240.0 / (22.5f64).to_radians().tan();
    let moved: Vec<Event> = events
        .iter()
        .map(|e| {
            let (x, y) = through_the_lens(e.x, e.y, f);
            Event { x, y, ..*e }
        })
        .collect();
    let (file, yaml) = (dir.join("big.raw"), dir.join("camera.yaml"));
    let mut bytes = Vec::new();
    evt3::write(&mut bytes, 1280, 960, &moved).unwrap();
    std::fs::write(&file, bytes).unwrap();
    let info = CAMERA_INFO
        .replace("FX", &format!("{}", 2.0 * f))
        .replace("FY", &format!("{}", 2.0 * f));
    std::fs::write(&yaml, info).unwrap();
    let decoded = decode(&file, &["--calibration", yaml.to_str().unwrap()]);
    assert_eq!(
        (decoded["width_px"].as_u64(), decoded["height_px"].as_u64()),
        (Some(1280), Some(960))
    );
    assert_eq!(decoded["remapped"], true);
    // Remapping rounds to the nearest reference pixel: the same payloads.
    assert_decodes_as_live(&decoded, false);

    // The file and the calibration must agree on the sensor.
    let small = dir.join("small.raw");
    let mut bytes = Vec::new();
    evt3::write(&mut bytes, 640, 480, &events[..10]).unwrap();
    std::fs::write(&small, bytes).unwrap();
    let out = waggle()
        .args(["decode", "--events"])
        .arg(&small)
        .args([VIEWPOINT, "--calibration"])
        .arg(&yaml)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("640×480") && err.contains("1280×960"), "{err}");
}

#[test]
fn evt2_and_dat_files_of_the_live_events_decode_as_the_live_link() {
    let dir = scratch().join("prophesee");
    std::fs::create_dir_all(&dir).unwrap();
    let events = &live().1;
    type Writer = fn(&mut Vec<u8>, &[Event]) -> Vec<u8>;
    let files: [(&str, &str, Writer); 2] = [
        ("O1.evt2.raw", "evt2", |b, e| {
            evt2::write(b, 640, 480, e).unwrap();
            std::mem::take(b)
        }),
        ("O1_td.dat", "dat", |b, e| {
            dat::write(b, 640, 480, e).unwrap();
            std::mem::take(b)
        }),
    ];
    for (name, format, write) in files {
        let path = dir.join(name);
        std::fs::write(&path, write(&mut Vec::new(), events)).unwrap();
        let decoded = decode(&path, &[]);
        assert_eq!(decoded["format"], format);
        assert_eq!(decoded["events"], events.len() as u64);
        assert_decodes_as_live(&decoded, true);
    }
}

#[test]
fn unknown_and_damaged_files_are_refused_naming_them() {
    let dir = scratch().join("bad");
    std::fs::create_dir_all(&dir).unwrap();
    let refuse = |file: &Path, args: &[&str]| {
        let out = waggle()
            .args(["decode", "--events"])
            .arg(file)
            .args([VIEWPOINT])
            .args(args)
            .output()
            .unwrap();
        assert!(!out.status.success(), "{} decoded", file.display());
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let unknown = dir.join("clip.bin");
    std::fs::write(&unknown, b"RIFF....WAVEfmt ").unwrap();
    let err = refuse(&unknown, &[]);
    assert!(
        err.contains("clip.bin") && err.contains("--format"),
        "{err}"
    );
    // An AEDAT4 file cut inside its first packet.
    let mut bytes = Vec::new();
    aedat4::write(
        &mut bytes,
        640,
        480,
        &live().1[..20_000],
        &aedat4::WriteOptions::default(),
    )
    .unwrap();
    let cut = dir.join("cut.aedat4");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let err = refuse(&cut, &[]);
    assert!(err.contains("cut.aedat4") && err.contains("byte"), "{err}");
    let err = refuse(&cut, &["--topic", "/O1/events"]);
    assert!(err.contains("not a bag"), "{err}");
}
