//! Text and framed inputs: camera calibration YAML, case, study and compose TOML, a receiver
//! plug-in's replies.
//!
//! [`calibration`] parses a ROS `camera_info` / OpenCV YAML document; accepted intrinsics must
//! survive being written as YAML and read again, and the remaps Waggle builds from them (events
//! and images into the reference camera) must be built. [`case_toml`] checks that a case reads
//! the same from its TOML as from that TOML printed again. [`study_toml`] checks the same of a
//! link study (the lab prints a study into `run.json` and a merge reads it back) and runs the
//! study file's own checks. [`compose_toml`] checks that a compose file prints and parses back
//! equal, with the same verdict of its checks. [`plugin_reply`] reads a worker's
//! frame as the plug-in host does and re-frames what it read.

use std::io::Cursor;

use compose_file::Compose;
use event_camera::calibration::{EventRemap, ImageRemap, Intrinsics};
use receiver_plugin::wire::{MAX_REPLY_BYTES, encode, read_reply};
use run_format::case::Case;
use run_format::study_file::StudyFile;

/// `i` as a ROS `camera_info` YAML document.
fn calibration_yaml(i: &Intrinsics) -> String {
    let d: Vec<String> = i.distortion.iter().map(|v| format!("{v:?}")).collect();
    format!(
        "image_width: {}\nimage_height: {}\ncamera_matrix:\n  rows: 3\n  cols: 3\n  data: \
         [{:?}, 0.0, {:?}, 0.0, {:?}, {:?}, 0.0, 0.0, 1.0]\ndistortion_model: \
         rational_polynomial\ndistortion_coefficients:\n  rows: 1\n  cols: 8\n  data: [{}]\n",
        i.width_px,
        i.height_px,
        i.fx_px,
        i.cx_px,
        i.fy_px,
        i.cy_px,
        d.join(", ")
    )
}

/// A calibration YAML document.
pub fn calibration(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(intrinsics) = Intrinsics::from_yaml(text) else {
        return;
    };
    let yaml = calibration_yaml(&intrinsics);
    let back = Intrinsics::from_yaml(&yaml).expect("intrinsics Waggle wrote read back");
    assert_eq!(back, intrinsics, "{yaml}");
    let events = EventRemap::new(&intrinsics);
    let _ = events.map(intrinsics.width_px - 1, intrinsics.height_px - 1);
    let images = ImageRemap::new(&intrinsics);
    let _ = images;
}

/// A case file's TOML text.
pub fn case_toml(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(case) = Case::from_text(text, "fuzz input") else {
        return;
    };
    let table: toml::Table = toml::from_str(text).expect("a case is a TOML table");
    let printed = toml::to_string(&table).expect("a TOML table prints");
    let again = Case::from_text(&printed, "printed again")
        .unwrap_or_else(|e| panic!("the case printed again is refused: {e}\n{printed}"));
    assert_eq!(format!("{again:?}"), format!("{case:?}"), "{printed}");
}

/// The most settings a study's input may ask for before the target stops counting them: a
/// crossed study's settings are the product of its level counts.
const MAX_SETTINGS: usize = 4096;

/// A link study file's TOML text.
pub fn study_toml(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(study) = StudyFile::from_toml(text) else {
        return;
    };
    let printed = study
        .to_toml()
        .unwrap_or_else(|e| panic!("a study that parses does not print: {e}\n{study:?}"));
    let again = StudyFile::from_toml(&printed)
        .unwrap_or_else(|e| panic!("the study printed again is refused: {e}\n{printed}"));
    assert_eq!(format!("{again:?}"), format!("{study:?}"), "{printed}");
    let shape = study.check_shape();
    let cross = study.check_cross();
    let _ = study.trial_limit();
    let counts = study.vary.iter().map(|v| v.levels.len());
    let expected = if study.cross {
        counts.fold(1usize, usize::saturating_mul)
    } else {
        counts.fold(0usize, usize::saturating_add)
    };
    if study.cross && expected > run_format::study_file::MAX_CROSSED_SETTINGS {
        assert!(cross.is_err(), "{expected} crossed settings accepted");
    }
    if shape.is_ok() && expected <= MAX_SETTINGS {
        let settings = study.settings();
        assert_eq!(settings.len(), expected);
        let width = if study.cross { study.vary.len() } else { 1 };
        assert!(settings.iter().all(|s| s.len() == width));
    }
}

/// A compose file's TOML text (`waggle up`, `waggle run`, `waggle bundle`).
pub fn compose_toml(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(compose) = Compose::parse(text) else {
        return;
    };
    let checked = compose.check().map_err(|e| chain(&e));
    let printed = compose
        .to_toml()
        .unwrap_or_else(|e| panic!("a compose file that parses does not print: {e}\n{compose:?}"));
    let again = Compose::parse(&printed)
        .unwrap_or_else(|e| panic!("the compose file printed again is refused: {e}\n{printed}"));
    assert_eq!(again, compose, "{printed}");
    assert_eq!(again.check().map_err(|e| chain(&e)), checked, "{printed}");
    assert_eq!(Compose::from_toml(text).is_ok(), checked.is_ok());
    if checked.is_ok() {
        // What a checked file's launcher asks of it must answer, not panic.
        let _ = compose.sensor().expect("a checked file's cameras agree");
        for host in compose.hosts() {
            let _ = (compose.dial_from(&host), compose.users_on(&host));
        }
    }
}

/// An error and its sources, as `anyhow` prints them with `{:#}`.
fn chain(e: &dyn std::error::Error) -> String {
    std::iter::successors(Some(e), |e| e.source())
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join(": ")
}

/// A worker's reply frame.
pub fn plugin_reply(data: &[u8]) {
    let mut r = Cursor::new(data);
    let Ok(header) = read_reply(&mut r, MAX_REPLY_BYTES) else {
        return;
    };
    assert!(r.position() as usize <= data.len());
    let framed = encode(&header, &[]);
    let back = read_reply(&mut Cursor::new(&framed), MAX_REPLY_BYTES)
        .expect("a header Waggle framed reads back");
    assert_eq!(back, header);
}
