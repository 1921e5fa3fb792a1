//! Real cameras' recordings decode to the fields their publisher recorded: the files and the
//! SHA3-224 digests of their decoded `t` (µs, as recorded), `x`, `y` and `on` come from the faery
//! source package that `deploy/setup.sh` unpacks into `third_party/faery/` (its `assets.py`).

use std::path::PathBuf;

use event_camera::{Event, Polarity};
use sha3::{Digest, Sha3_224};

fn faery_dir() -> PathBuf {
    std::env::var_os("WAGGLE_THIRD_PARTY")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../third_party"))
        .join("faery")
}

fn recording(name: &str) -> Vec<u8> {
    let path = faery_dir().join("data").join(name);
    std::fs::read(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (run `bash deploy/setup.sh`, which unpacks faery's recordings)",
            path.display()
        )
    })
}

/// The digests `assets.py` publishes for `name`, field by field.
fn published(name: &str) -> Vec<(String, String)> {
    let assets = std::fs::read_to_string(faery_dir().join("assets.py")).expect("faery's assets.py");
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

fn assert_published(name: &str, events: &[Event]) {
    let want = published(name);
    let got = digests(events);
    for (field, digest) in &got {
        let expected = want
            .iter()
            .find(|(f, _)| f == field)
            .unwrap_or_else(|| panic!("assets.py has no {field} digest for {name}"));
        assert_eq!(
            digest,
            &expected.1,
            "{name}: field {field} of {} events differs from faery's digest",
            events.len()
        );
    }
}

#[test]
fn an_evk4_evt3_recording_decodes_to_its_published_digests() {
    let bytes = recording("evt3.raw");
    let raw = event_formats::evt3::read(&bytes).expect("evt3.raw");
    assert_eq!(
        raw.geometry,
        Some(event_formats::evt3::Geometry {
            width: 1280,
            height: 720
        })
    );
    assert_published("evt3.raw", &raw.events);
}

#[test]
fn a_davis346_aedat4_recording_from_dv_decodes_to_its_published_digests() {
    let bytes = recording("davis346.aedat4");
    let file = event_formats::aedat4::read(&bytes).expect("davis346.aedat4");
    assert_eq!(
        file.geometry,
        Some(event_formats::evt3::Geometry {
            width: 346,
            height: 260
        })
    );
    assert_eq!(file.compression, event_formats::aedat4::Compression::Lz4);
    // The reader counts Unix time from the first event; faery's digests are of the raw stamps.
    let origin_ns = u64::try_from(file.origin_us).unwrap() * 1000;
    let raw: Vec<Event> = file
        .events
        .iter()
        .map(|e| Event {
            t_ns: e.t_ns + origin_ns,
            ..*e
        })
        .collect();
    assert_published("davis346.aedat4", &raw);
}

#[test]
fn a_gen3_evt2_recording_decodes_to_its_published_digests() {
    let bytes = recording("evt2.raw");
    assert!(event_formats::evt2::is_evt2(&bytes));
    let raw = event_formats::evt2::read(&bytes).expect("evt2.raw");
    assert_published("evt2.raw", &raw.events);
}

#[test]
fn the_evk4_recording_as_dat_decodes_to_its_published_digests() {
    let bytes = recording("gen4.dat");
    let dat = event_formats::dat::read(&bytes).expect("gen4.dat");
    assert_eq!(
        dat.geometry,
        Some(event_formats::dat::Geometry {
            width: 1280,
            height: 720
        })
    );
    assert_published("gen4.dat", &dat.events);
}
