//! Real cameras' recordings decode to the fields their publisher recorded: the files and the
//! SHA3-224 digests of their decoded `t` (µs, as recorded), `x`, `y` and `on` come from the faery
//! and aedat source packages that `deploy/setup.sh` unpacks into `third_party/faery/` and
//! `third_party/aedat/` (each package's `assets.py`).

use std::path::PathBuf;

use event_camera::{Event, Polarity};
use sha3::{Digest, Sha3_224};

/// Where `deploy/setup.sh` unpacked the source package `package`'s test data.
fn package_dir(package: &str) -> PathBuf {
    std::env::var_os("WAGGLE_THIRD_PARTY")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../third_party"))
        .join(package)
}

fn recording(package: &str, name: &str) -> Vec<u8> {
    let path = package_dir(package).join("data").join(name);
    std::fs::read(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (run `bash deploy/setup.sh`, which unpacks {package}'s recordings)",
            path.display()
        )
    })
}

/// The digests `package`'s `assets.py` publishes for `name`, field by field.
fn published(package: &str, name: &str) -> Vec<(String, String)> {
    let assets = std::fs::read_to_string(package_dir(package).join("assets.py"))
        .unwrap_or_else(|e| panic!("{package}'s assets.py: {e}"));
    let entry = format!("dirname / \"data\" / \"{name}\"");
    let from = assets
        .find(&entry)
        .unwrap_or_else(|| panic!("assets.py lists no {name}"));
    let rest = &assets[from..];
    let open = rest.find("field_to_digest={").expect("field_to_digest") + "field_to_digest={".len();
    let close = open + rest[open..].find('}').expect("end of field_to_digest");
    rest[open..close]
        .split(',')
        .filter_map(|pair| {
            let (field, digest) = pair.split_once(':')?;
            Some((
                field.trim().trim_matches('"').to_string(),
                digest.trim().trim_matches('"').to_string(),
            ))
        })
        .collect()
}

/// SHA3-224 of each field as faery's arrays hold it: `t` u64 µs, `x` and `y` u16, `on` one byte,
/// little-endian.
fn digests(events: &[Event]) -> Vec<(String, String)> {
    let mut t = Sha3_224::new();
    let mut x = Sha3_224::new();
    let mut y = Sha3_224::new();
    let mut on = Sha3_224::new();
    for e in events {
        t.update((e.t_ns / 1000).to_le_bytes());
        x.update(e.x.to_le_bytes());
        y.update(e.y.to_le_bytes());
        on.update([u8::from(e.polarity == Polarity::On)]);
    }
    let hex = |h: Sha3_224| {
        h.finalize()
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect::<String>()
    };
    vec![
        ("t".into(), hex(t)),
        ("x".into(), hex(x)),
        ("y".into(), hex(y)),
        ("on".into(), hex(on)),
    ]
}

fn assert_published(package: &str, name: &str, events: &[Event]) {
    let want = published(package, name);
    let got = digests(events);
    for (field, digest) in &got {
        let expected = want
            .iter()
            .find(|(f, _)| f == field)
            .unwrap_or_else(|| panic!("assets.py has no {field} digest for {name}"));
        assert_eq!(
            digest,
            &expected.1,
            "{name}: field {field} of {} events differs from {package}'s digest",
            events.len()
        );
    }
}

#[test]
fn an_evk4_evt3_recording_decodes_to_its_published_digests() {
    let bytes = recording("faery", "evt3.raw");
    let raw = event_formats::evt3::read(&bytes).expect("evt3.raw");
    assert_eq!(
        raw.geometry,
        Some(event_formats::evt3::Geometry {
            width: 1280,
            height: 720
        })
    );
    assert_published("faery", "evt3.raw", &raw.events);
}

#[test]
fn a_davis346_aedat4_recording_from_dv_decodes_to_its_published_digests() {
    let bytes = recording("faery", "davis346.aedat4");
    let file = event_formats::aedat4::read(&bytes).expect("davis346.aedat4");
    assert_eq!(
        file.geometry,
        Some(event_formats::evt3::Geometry {
            width: 346,
            height: 260
        })
    );
    assert_eq!(file.compression, event_formats::aedat4::Compression::Lz4);
    assert_published("faery", "davis346.aedat4", &as_recorded(&file));
}

/// The reader counts Unix time from the first event; the published digests are of the raw stamps.
fn as_recorded(file: &event_formats::aedat4::Aedat4Recording) -> Vec<Event> {
    let origin_ns = u64::try_from(file.origin_us).unwrap() * 1000;
    file.events
        .iter()
        .map(|e| Event {
            t_ns: e.t_ns + origin_ns,
            ..*e
        })
        .collect()
}

#[test]
fn a_davis346_aedat4_recording_with_frames_imus_and_triggers_decodes_to_its_published_digests() {
    let bytes = recording("aedat", "test_data.aedat4");
    let file = event_formats::aedat4::read(&bytes).expect("test_data.aedat4");
    assert_eq!(
        file.geometry,
        Some(event_formats::evt3::Geometry {
            width: 346,
            height: 260
        })
    );
    assert_published("aedat", "test_data.aedat4", &as_recorded(&file));
}

#[test]
fn a_gen3_evt2_recording_decodes_to_its_published_digests() {
    let bytes = recording("faery", "evt2.raw");
    assert!(event_formats::evt2::is_evt2(&bytes));
    let raw = event_formats::evt2::read(&bytes).expect("evt2.raw");
    assert_published("faery", "evt2.raw", &raw.events);
}

#[test]
fn the_evk4_recording_as_dat_decodes_to_its_published_digests() {
    let bytes = recording("faery", "gen4.dat");
    let dat = event_formats::dat::read(&bytes).expect("gen4.dat");
    assert_eq!(
        dat.geometry,
        Some(event_formats::dat::Geometry {
            width: 1280,
            height: 720
        })
    );
    assert_published("faery", "gen4.dat", &dat.events);
}
