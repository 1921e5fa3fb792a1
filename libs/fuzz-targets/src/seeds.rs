//! Seed corpora made with Waggle's own writers: every seed is bytes Waggle itself produces (the
//! wire encoder, the event-file writers, the recorder, the bag writer, the session certificate
//! issuer, the lab's record and render cache encoders, the compose file printer) or a case or
//! study file of the repository, never a third party's data. `examples/write_seeds.rs` writes them to
//! `fuzz/corpus/<target>/`.

use std::collections::BTreeMap;
use std::io::Cursor;
use std::path::Path;

use event_camera::{Event, Polarity};
use proto::{ClockTick, EventPacket, Fault, FaultKind, Keys, ObserverId, TICK_NS};
use recording::{RecordError, RecorderOptions, SessionInfo, SessionWriter};
use ros2_bag::messages::{EventPacketMsg, HeaderMsg, ImageMsg};
use ros2_bag::{BagWriter, QosProfile, Ros2Error, RosMessage};

use crate::wire::KEYS;

mod runs;
use runs::{compose_seeds, render_cache_seed, trial_record_seeds};

/// Why the seeds could not be made.
#[derive(Debug, thiserror::Error)]
pub enum SeedError {
    #[error("seed {target}/{name}: {source}")]
    Io {
        target: &'static str,
        name: String,
        #[source]
        source: std::io::Error,
    },
    #[error("writing the seed recording: {0}")]
    Record(#[from] RecordError),
    #[error("writing the seed bag: {0}")]
    Bag(#[from] Ros2Error),
    #[error("writing a seed event file: {0}")]
    Events(String),
    #[error("making a seed certificate: {0}")]
    Certificate(String),
}

/// One seed: its target, a file name, its bytes.
pub type SeedFile = (&'static str, String, Vec<u8>);

/// A few events on a 64×48 sensor, in time order.
fn events() -> Vec<Event> {
    (0..40u16)
        .map(|k| Event {
            t_ns: u64::from(k) * 1_500_000 + u64::from(k % 3) * 1000,
            x: k * 7 % 64,
            y: k * 5 % 48,
            polarity: if k % 2 == 0 {
                Polarity::On
            } else {
                Polarity::Off
            },
        })
        .collect()
}

fn packet(tick: u64) -> EventPacket {
    let evs: Vec<_> = (0..12u16)
        .map(|i| {
            let p = if i % 3 == 0 {
                proto::Polarity::On
            } else {
                proto::Polarity::Off
            };
            (i * 13 % 640, i * 7 % 480, u32::from(i) * 1000, p)
        })
        .collect();
    EventPacket::from_events(
        tick - 1,
        ((tick - 1) * TICK_NS, tick * TICK_NS),
        (640, 480),
        &evs,
    )
}

/// Selector of `key` in [`KEYS`], then `body`.
fn keyed(key: &str, body: Vec<u8>) -> Vec<u8> {
    let k = KEYS.iter().position(|k| *k == key).expect("a key of KEYS");
    let mut out = vec![u8::try_from(k).expect("few keys")];
    out.extend(body);
    out
}

fn wire_seeds(out: &mut Vec<SeedFile>) {
    let o1 = ObserverId::new("O1").expect("valid id");
    let clock = proto::encode(&ClockTick::at(7).expect("tick 7"));
    out.push(("wire_message", "clock".into(), keyed("clock", clock)));
    let events = proto::encode(&packet(3));
    out.push((
        "wire_message",
        "events".into(),
        keyed("sensor/O1/events", events),
    ));
    let fault = Fault {
        observer: o1.clone(),
        kind: FaultKind::BlackInput,
        from_ns: 0,
        until_ns: Some(2 * TICK_NS),
    };
    let fault = keyed("fault/O1", proto::encode(&fault));
    out.push(("wire_message", "fault".into(), fault));
    let keys = Keys::new("s").expect("valid session");
    for (name, key) in [
        ("events", keys.sensor_events(&o1)),
        ("clock", keys.clock()),
        ("fault", keys.of(&proto::Key::Fault(o1.clone()))),
    ] {
        let rest = key.strip_prefix("waggle/s/").expect("a key of the session");
        out.push(("wire_key", name.into(), rest.as_bytes().to_vec()));
    }
}

fn event_file_seeds(out: &mut Vec<SeedFile>) -> Result<(), SeedError> {
    use event_formats::aedat4::{Compression, WriteOptions};
    let ev = events();
    let err = |e: &dyn std::fmt::Display| SeedError::Events(e.to_string());
    let mut b = Vec::new();
    event_formats::evt3::write(&mut b, 64, 48, &ev).map_err(|e| err(&e))?;
    out.push(("evt3", "waggle-64x48".into(), b));
    let mut b = Vec::new();
    event_formats::evt2::write(&mut b, 64, 48, &ev).map_err(|e| err(&e))?;
    out.push(("evt2", "waggle-64x48".into(), b));
    let mut b = Vec::new();
    event_formats::dat::write(&mut b, 64, 48, &ev).map_err(|e| err(&e))?;
    out.push(("dat", "waggle-64x48".into(), b));
    for compression in [Compression::None, Compression::Lz4, Compression::Zstd] {
        let opts = WriteOptions {
            compression,
            events_per_packet: 16,
        };
        let mut b = Vec::new();
        event_formats::aedat4::write(&mut b, 64, 48, &ev, &opts).map_err(|e| err(&e))?;
        out.push(("aedat4", compression.name().to_lowercase(), b));
    }
    // Structured input: width, height, compression, then (dt, x, y, on) steps.
    let steps: Vec<u8> = (0..32u8).flat_map(|k| [k, 0, k, 1, k, 2, k % 2]).collect();
    let mut b = vec![64, 0, 48, 0, 1];
    b.extend(steps);
    out.push(("event_writers", "small-sensor".into(), b));
    Ok(())
}

fn recording_seed(out: &mut Vec<SeedFile>) -> Result<(), SeedError> {
    let keys = Keys::new("s").expect("valid session");
    let o1 = ObserverId::new("O1").expect("valid id");
    let info = SessionInfo {
        sensor_args: Vec::new(),
        events_from_input: false,
        session: "s".into(),
        observers: 1,
        case_name: Some("seed".into()),
        case_toml: None,
        modality: Some("events".into()),
    };
    let options = RecorderOptions {
        event_view_period_ns: None,
        chunk_bytes: 2048,
        ..RecorderOptions::default()
    };
    let mut w = SessionWriter::new(Cursor::new(Vec::new()), &info, options)?;
    for k in 1..=4 {
        let tick = ClockTick::at(k).expect("early tick");
        w.record(&keys.clock(), &proto::encode(&tick))?;
        w.record(&keys.sensor_events(&o1), &proto::encode(&packet(k)))?;
    }
    let bytes = w.finish(BTreeMap::new())?.into_inner();
    out.push(("recording", "four-ticks".into(), bytes));
    Ok(())
}

/// Every seed message's header: O1's optical frame at 2.04 s.
fn header() -> Result<HeaderMsg, SeedError> {
    Ok(HeaderMsg::at(2_040_000_000, "O1/camera_optical")?)
}

fn event_packet_msg(seq: u64, events: &[Event]) -> Result<EventPacketMsg, SeedError> {
    let err = |e: event_formats::evt3::Evt3Error| SeedError::Events(e.to_string());
    let mut enc = event_formats::evt3::StreamEncoder::new(64, 48).map_err(err)?;
    let mut payload = Vec::new();
    enc.encode(events, &mut payload).map_err(err)?;
    Ok(EventPacketMsg {
        header: header()?,
        height: 48,
        width: 64,
        seq,
        time_base: 0,
        encoding: "evt3".into(),
        is_bigendian: false,
        events: payload,
    })
}

fn ros2_seeds(out: &mut Vec<SeedFile>, scratch: &Path) -> Result<(), SeedError> {
    let ev = events();
    let packet = event_packet_msg(0, &ev)?.to_cdr();
    for (selector, name) in [(0, "event-packet"), (3, "camera-packet")] {
        let mut cdr = vec![selector];
        cdr.extend(&packet);
        out.push(("ros2_cdr", name.into(), cdr));
    }
    let image = ImageMsg {
        header: header()?,
        height: 2,
        width: 2,
        encoding: "rgb8".into(),
        is_bigendian: 0,
        step: 6,
        data: (0..12).collect(),
    };
    let mut cdr = vec![1];
    cdr.extend(image.to_cdr());
    out.push(("ros2_cdr", "image-rgb8".into(), cdr));
    let dir = scratch.join("seed-bag");
    if dir.exists() {
        std::fs::remove_dir_all(&dir).map_err(|source| io("ros2_bag", "bag", source))?;
    }
    let mut bag = BagWriter::create(&dir)?;
    for (seq, half) in ev.chunks(20).enumerate() {
        let msg = event_packet_msg(seq as u64, half)?;
        bag.write("/O1/events", QosProfile::VOLATILE, seq as u64 * 1000, &msg)?;
    }
    let summary = bag.finish()?;
    let path = summary.dir.join(&summary.file_name);
    let bytes = std::fs::read(&path).map_err(|source| io("ros2_bag", "bag", source))?;
    out.push(("ros2_bag", "two-packets".into(), bytes));
    Ok(())
}

fn io(target: &'static str, name: &str, source: std::io::Error) -> SeedError {
    SeedError::Io {
        target,
        name: name.into(),
        source,
    }
}

fn text_seeds(out: &mut Vec<SeedFile>, root: &Path) -> Result<(), SeedError> {
    let yaml = "image_width: 64\nimage_height: 48\ncamera_matrix:\n  rows: 3\n  cols: 3\n  \
                data: [60.0, 0.0, 31.5, 0.0, 60.0, 23.5, 0.0, 0.0, 1.0]\n\
                distortion_model: plumb_bob\ndistortion_coefficients:\n  rows: 1\n  cols: 5\n  \
                data: [-0.1, 0.01, 0.001, -0.001, 0.0]\n";
    out.push((
        "calibration",
        "ros-camera-info".into(),
        yaml.as_bytes().to_vec(),
    ));
    let opencv = "%YAML:1.0\n---\nimage_width: 32\nimage_height: 24\ncamera_matrix: \
                  !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 30., 0., 15.5, \
                  0., 30., 11.5, 0., 0., 1. ]\n";
    out.push(("calibration", "opencv".into(), opencv.as_bytes().to_vec()));
    for name in ["one-observer", "dropout-o2"] {
        let text = run_format::case::case_source(name)
            .map_err(|e| io("case_toml", name, std::io::Error::other(e.to_string())))?;
        out.push(("case_toml", name.into(), text.into_bytes()));
    }
    for (name, text) in run_format::study::BUILT_IN {
        out.push(("study_toml", (*name).into(), text.as_bytes().to_vec()));
    }
    let custom = root.join("examples/custom-case.toml");
    let text = std::fs::read(&custom).map_err(|source| io("case_toml", "custom", source))?;
    out.push(("case_toml", "custom-case".into(), text));
    let reply = serde_json::json!({"ok": {"tokens": [{"token": "A", "t_ns": 40_000_000}]}});
    out.push((
        "plugin_reply",
        "ok".into(),
        receiver_plugin::wire::encode(&reply, &[]),
    ));
    let error = serde_json::json!({"error": "ValueError: bad frame"});
    out.push((
        "plugin_reply",
        "error".into(),
        receiver_plugin::wire::encode(&error, &[]),
    ));
    Ok(())
}

/// `cert`, a NUL byte, `key`: the input of `tls_pem`.
fn cert_and_key(cert: &str, key: &str) -> Vec<u8> {
    let mut out = cert.as_bytes().to_vec();
    out.push(0);
    out.extend_from_slice(key.as_bytes());
    out
}

/// An institution's CA made as `libs/bus`'s tests make one (a self-signed CA certificate and
/// its key), and a session's certificates issued by Waggle's own issuer: a leaf (no CA) with its
/// key, and the CA with the leaf's key.
fn tls_seeds(out: &mut Vec<SeedFile>) -> Result<(), SeedError> {
    let err = |e: &dyn std::fmt::Display| SeedError::Certificate(e.to_string());
    let key = rcgen::KeyPair::generate().map_err(|e| err(&e))?;
    let mut params = rcgen::CertificateParams::new(Vec::<String>::new()).map_err(|e| err(&e))?;
    params.is_ca = rcgen::IsCa::Ca(rcgen::BasicConstraints::Unconstrained);
    params
        .distinguished_name
        .push(rcgen::DnType::CommonName, "Example University robotics CA");
    let ca = params.self_signed(&key).map_err(|e| err(&e))?;
    let pair = cert_and_key(&ca.pem(), &key.serialize_pem());
    out.push(("tls_pem", "institution-ca".into(), pair));
    let mut files = BTreeMap::new();
    bus::tls::issue(
        "seed",
        &["sim".to_owned()],
        std::time::Duration::from_secs(3600),
        None,
        |path, text| {
            files.insert(
                path.file_name().map(|n| n.to_string_lossy().into_owned()),
                text.to_owned(),
            );
            Ok(())
        },
        Path::new("/seed"),
    )
    .map_err(|e| err(&e))?;
    let file = |name: &str| {
        files
            .get(&Some(name.to_owned()))
            .cloned()
            .unwrap_or_default()
    };
    let (leaf, leaf_key) = (file("sim.cert.pem"), file("sim.key.pem"));
    out.push((
        "tls_pem",
        "session-leaf".into(),
        cert_and_key(&leaf, &leaf_key),
    ));
    let other = cert_and_key(&ca.pem(), &leaf_key);
    out.push(("tls_pem", "ca-with-another-key".into(), other));
    Ok(())
}

/// Every target's seeds; `root` is the repository (for its example case file), `scratch` a
/// directory where the bag writer may create a bag.
pub fn seeds(root: &Path, scratch: &Path) -> Result<Vec<SeedFile>, SeedError> {
    let mut out = Vec::new();
    wire_seeds(&mut out);
    event_file_seeds(&mut out)?;
    recording_seed(&mut out)?;
    ros2_seeds(&mut out, scratch)?;
    text_seeds(&mut out, root)?;
    tls_seeds(&mut out)?;
    trial_record_seeds(&mut out)?;
    compose_seeds(&mut out)?;
    render_cache_seed(&mut out)?;
    Ok(out)
}
