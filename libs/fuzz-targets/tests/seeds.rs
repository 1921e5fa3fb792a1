//! The seeds are inputs the parsers accept: a seed that a parser refuses would start the fuzzer
//! on its error path only. Each is made again here and read by its parser.

use std::io::Cursor;
use std::path::Path;

#[test]
fn every_seed_is_accepted_by_its_parser() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let scratch = std::env::temp_dir().join(format!("waggle-seed-test-{}", std::process::id()));
    std::fs::create_dir_all(&scratch).unwrap();
    let seeds = fuzz_targets::seeds::seeds(&root, &scratch).unwrap();
    std::fs::remove_dir_all(&scratch).unwrap();
    let names: std::collections::BTreeSet<&str> = seeds.iter().map(|s| s.0).collect();
    for (name, _) in fuzz_targets::TARGETS {
        assert!(names.contains(name), "no seed for {name}");
    }
    for (target, name, bytes) in &seeds {
        let what = format!("{target}/{name}");
        match *target {
            "evt3" => assert_eq!(event_formats::evt3::read(bytes).unwrap().events.len(), 40),
            "evt2" => assert_eq!(event_formats::evt2::read(bytes).unwrap().events.len(), 40),
            "dat" => assert_eq!(event_formats::dat::read(bytes).unwrap().events.len(), 40),
            "aedat4" => assert_eq!(event_formats::aedat4::read(bytes).unwrap().events.len(), 40),
            "recording" => {
                let outcome = recording::read_recording_from::<recording::ReadError>(
                    Cursor::new(bytes),
                    &what,
                    |_| Ok(()),
                )
                .unwrap();
                assert!(outcome.complete, "{what}: {:?}", outcome.problem);
                assert!(
                    outcome.messages >= 8,
                    "{what}: {} messages",
                    outcome.messages
                );
            }
            "ros2_bag" => {
                let bag =
                    ros2_bag::ingest::read_event_bag_bytes(Path::new(&what), bytes, None, None)
                        .unwrap();
                assert_eq!((bag.messages, bag.events.len()), (2, 40), "{what}");
                assert_eq!((bag.width, bag.height), (64, 48));
            }
            "calibration" => {
                let text = std::str::from_utf8(bytes).unwrap();
                event_camera::calibration::Intrinsics::from_yaml(text).unwrap();
            }
            "case_toml" => {
                let text = std::str::from_utf8(bytes).unwrap();
                run_format::case::Case::from_text(text, &what).unwrap();
            }
            "plugin_reply" => {
                receiver_plugin::wire::read_reply(&mut Cursor::new(bytes), 1 << 20).unwrap();
            }
            "wire_key" => {
                assert!(proto::Key::parse_rest(std::str::from_utf8(bytes).unwrap()).is_some());
            }
            "study_toml" => {
                let text = std::str::from_utf8(bytes).unwrap();
                let study = run_format::study_file::StudyFile::from_toml(text);
                if text.contains("\narms = ") {
                    assert!(study.is_err(), "{what}: a mission study is no link study");
                } else {
                    study.unwrap().check_shape().unwrap();
                }
            }
            "trial_record" => {
                use run_format::trial_record::{TrialRecord, decode, parse};
                let stored = decode::<TrialRecord>(bytes).unwrap();
                let (point, index) = (stored.body.point.clone(), stored.body.index);
                parse::<TrialRecord>(bytes, &point, index).unwrap();
            }
            "tls_pem" => {
                let at = bytes.iter().position(|&b| b == 0).unwrap();
                let cert = std::str::from_utf8(&bytes[..at]).unwrap().to_owned();
                let key = std::str::from_utf8(&bytes[at + 1..]).unwrap().to_owned();
                let paths = (Path::new("ca.crt"), Path::new("ca.key"));
                let now = fuzz_targets::tls::NOW_UNIX_S;
                let got = bus::tls::ExistingCa::from_pem(cert, key, paths, now);
                match name.as_str() {
                    "institution-ca" => assert!(got.is_ok(), "{what}: {got:?}"),
                    "session-leaf" => assert!(
                        got.unwrap_err()
                            .to_string()
                            .contains("not a CA certificate"),
                        "{what}"
                    ),
                    _ => assert!(
                        got.unwrap_err()
                            .to_string()
                            .contains("not the key of the CA"),
                        "{what}"
                    ),
                }
            }
            "compose_toml" => {
                let text = std::str::from_utf8(bytes).unwrap();
                let compose = compose_file::Compose::from_toml(text).unwrap();
                assert_eq!(compose.to_toml().unwrap(), text, "{what}");
            }
            "render_cache" => {
                use run_format::render_cache::{CacheEntry, decode};
                assert!(bytes.len() < 64 << 10, "{what}: {} bytes", bytes.len());
                type Ideal = std::collections::BTreeMap<
                    proto::Modality,
                    Vec<run_format::link_out::ObserverOut>,
                >;
                let entry: CacheEntry<Ideal> = decode(bytes, None).unwrap();
                assert_eq!(entry.pixels.len(), 2, "{what}");
                assert_eq!(
                    &entry.encode().unwrap(),
                    bytes,
                    "{what}: encodes differently"
                );
            }
            _ => {}
        }
    }
}
