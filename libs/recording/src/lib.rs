//! Recorder: every message of a Waggle session into one MCAP file, and reading it back.
//!
//! - [`topics`]: key → message type and channel topic, decoding with [`proto::decode`], sim
//!   time of each message;
//! - [`writer`]: [`SessionWriter`], raw wire bytes per key (lossless, empty event packets
//!   included) plus Foxglove viewing channels, zstd chunks of bounded size, session metadata;
//! - [`reader`]: [`read_recording`], chunk-by-chunk streaming that survives a cut file;
//! - [`records`]: the MCAP records the reader parses, their lengths checked before `mcap` allocates;
//! - [`views`], [`foxglove`]: event-frame pictures, log lines, the 3D scene and Foxglove's
//!   official schemas (protobuf).
//!
//! Pure apart from the writer's and reader's byte streams: the `recorder-node` binary adds the
//! Zenoh subscription, the start-up handshake and signal handling.

pub mod foxglove;
pub mod reader;
pub mod records;
pub mod topics;
pub mod views;
pub mod writer;

pub use reader::{
    Damage, ReadError, ReadOutcome, RecordedMessage, leading_metadata, read_recording,
    read_recording_from,
};
pub use topics::{Decoded, MessageKind, RAW_ENCODING, Topic, classify, decode};
pub use writer::{
    EVENTS_NOT_RECORDED, RECORDER_METADATA, RecordError, RecordStats, Recorded, RecorderOptions,
    SCENE_TOPIC, SESSION_METADATA, SessionInfo, SessionWriter, UnrecordedPackets, ViewTap,
};

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;
    use std::io::Cursor;

    use proto::{ClockTick, EventPacket, Keys, ObserverId, Polarity, TICK_NS};

    use super::*;

    fn packet(tick: u64, n: usize) -> EventPacket {
        let events: Vec<_> = (0..n)
            .map(|i| {
                let polarity = if i % 3 == 0 {
                    Polarity::On
                } else {
                    Polarity::Off
                };
                let dt_ns = (i as u32 * 1000) % 40_000_000;
                ((i * 7 % 640) as u16, (i * 3 % 480) as u16, dt_ns, polarity)
            })
            .collect();
        EventPacket::from_events(
            tick - 1,
            ((tick - 1) * TICK_NS, tick * TICK_NS),
            (640, 480),
            &events,
        )
    }

    /// A recording of `ticks` ticks: clock and one event packet per tick (every 4th empty),
    /// plus an unknown key and an undecodable payload.
    fn record(ticks: u64, options: RecorderOptions) -> (Vec<u8>, Vec<Vec<u8>>) {
        let keys = Keys::new("t").unwrap();
        let o1 = ObserverId::new("O1").unwrap();
        let info = SessionInfo {
            sensor_args: Vec::new(),
            events_from_input: false,
            session: "t".into(),
            observers: 1,
            case_name: Some("nominal-3".into()),
            case_toml: Some("name = 'x'".into()),
            modality: Some("events".into()),
        };
        let mut w = SessionWriter::new(Cursor::new(Vec::new()), &info, options).unwrap();
        let mut sent = Vec::new();
        for k in 1..=ticks {
            w.record(&keys.clock(), &proto::encode(&ClockTick::at(k).unwrap()))
                .unwrap();
            let bytes = proto::encode(&packet(k, if k % 4 == 0 { 0 } else { 500 }));
            assert!(matches!(
                w.record(&keys.sensor_events(&o1), &bytes).unwrap(),
                Recorded::Message {
                    kind: MessageKind::EventPacket,
                    mission_end: false
                }
            ));
            sent.push(bytes);
        }
        assert!(matches!(
            w.record("waggle/t/what/is/this", b"??").unwrap(),
            Recorded::UnknownKey
        ));
        assert!(matches!(
            w.record(&keys.clock(), b"\x02\x00garbage").unwrap(),
            Recorded::Undecodable { .. }
        ));
        assert_eq!(w.stats().unknown_keys.len(), 1);
        assert_eq!(w.stats().undecodable["/clock"], 1);
        let bytes = w.finish(Default::default()).unwrap().into_inner();
        (bytes, sent)
    }

    /// (topic, schema name, log time, bytes) of each message read.
    type Read = Vec<(String, String, u64, Vec<u8>)>;

    fn read_bytes(bytes: &[u8]) -> (ReadOutcome, Read) {
        let path = std::env::temp_dir().join(format!(
            "recorder-test-{}-{}.mcap",
            std::process::id(),
            bytes.len()
        ));
        std::fs::write(&path, bytes).unwrap();
        let mut got = Vec::new();
        let out = read_recording::<ReadError>(&path, |m| {
            got.push((
                m.topic.to_string(),
                m.schema.to_string(),
                m.log_time_ns,
                m.data.to_vec(),
            ));
            Ok(())
        });
        let _ = std::fs::remove_file(&path);
        (out.unwrap(), got)
    }

    #[test]
    fn event_packets_round_trip_byte_for_byte_with_metadata() {
        let (bytes, sent) = record(
            30,
            RecorderOptions {
                event_view_period_ns: Some(200_000_000),
                ..RecorderOptions::default()
            },
        );
        let (out, got) = read_bytes(&bytes);
        assert!(out.complete, "{:?}", out.problem);
        assert_eq!(out.metadata[SESSION_METADATA]["case"], "nominal-3");
        assert_eq!(out.metadata[SESSION_METADATA]["modality"], "events");
        assert!(out.metadata[RECORDER_METADATA]["messages"].contains("/sensor/O1/events"));
        let packets: Vec<_> = got.iter().filter(|m| m.0 == "/sensor/O1/events").collect();
        assert_eq!(packets.len(), 30);
        for (k, (m, s)) in packets.iter().zip(&sent).enumerate() {
            assert_eq!(&m.3, s, "packet {k}");
            assert_eq!(m.1, "waggle.EventPacket");
            assert_eq!(m.2, (k as u64 + 1) * TICK_NS, "log time = end watermark");
            let p: EventPacket = proto::decode(&m.3).unwrap();
            assert_eq!(p.is_empty(), (k + 1) % 4 == 0);
        }
        // 200 ms view: one picture per 5 packets.
        let images: Vec<_> = got.iter().filter(|m| m.0 == "/view/O1/events").collect();
        assert_eq!(images.len(), 6);
        // The schema the live view promised for this channel before the first image came.
        let promised = foxglove::ViewKind::Image.schema().name;
        assert!(images.iter().all(|m| m.1 == promised));
        assert!(got.iter().any(|m| m.0 == "/unknown/what/is/this"));
        assert_eq!(got.iter().filter(|m| m.0 == "/clock").count(), 31);
    }

    #[test]
    fn a_recording_of_the_input_keeps_no_packet_but_their_digest_and_the_sensor() {
        let keys = Keys::new("i").unwrap();
        let o1 = ObserverId::new("O1").unwrap();
        let sensor_args: Vec<String> = ["--sensor-preset", "v2e-noisy", "--seed", "9"]
            .map(String::from)
            .into();
        let info = SessionInfo {
            session: "i".into(),
            observers: 1,
            modality: Some("events".into()),
            sensor_args: sensor_args.clone(),
            events_from_input: true,
            ..SessionInfo::default()
        };
        let options = RecorderOptions {
            event_view_period_ns: Some(200_000_000),
            events_from_input: true,
            ..RecorderOptions::default()
        };
        let mut w = SessionWriter::new(Cursor::new(Vec::new()), &info, options).unwrap();
        let mut digest = 0;
        let mut events = 0;
        for k in 1..=20u64 {
            let frame = proto::RgbFrame::rendered(k - 1, k * TICK_NS, (2, 1), vec![k as u8; 6]);
            let input = proto::encode(&proto::RgbUpdate::key(&frame));
            w.record(&keys.camera_input(&o1), &input).unwrap();
            let p = packet(k, (k as usize) * 10);
            events += p.len() as u64;
            let bytes = proto::encode(&p);
            digest = proto::camera::digest(digest, &bytes);
            w.record(&keys.sensor_events(&o1), &bytes).unwrap();
        }
        let bytes = w.finish(Default::default()).unwrap().into_inner();
        let (out, got) = read_bytes(&bytes);
        assert!(out.complete);
        assert!(!got.iter().any(|m| m.0 == "/sensor/O1/events"));
        assert_eq!(got.iter().filter(|m| m.0 == "/camera/O1/input").count(), 20);
        // The packets still make the event view; the input makes no RGB view.
        assert!(got.iter().any(|m| m.0 == "/view/O1/events"));
        assert!(!got.iter().any(|m| m.0 == "/view/O1/rgb"));
        let back = SessionInfo::from_metadata(&out.metadata[SESSION_METADATA]);
        assert_eq!(back, info);
        let kept: BTreeMap<String, UnrecordedPackets> =
            serde_json::from_str(&out.metadata[RECORDER_METADATA][EVENTS_NOT_RECORDED]).unwrap();
        assert_eq!(
            kept["O1"],
            UnrecordedPackets {
                packets: 20,
                events,
                digest
            }
        );
    }

    #[test]
    fn every_rgb_update_is_recorded_raw_and_views_come_at_the_reduced_rate() {
        let keys = Keys::new("r").unwrap();
        let o2 = ObserverId::new("O2").unwrap();
        let info = SessionInfo {
            session: "r".into(),
            observers: 2,
            ..SessionInfo::default()
        };
        let options = RecorderOptions {
            rgb_every: 25,
            ..RecorderOptions::default()
        };
        let mut w = SessionWriter::new(Cursor::new(Vec::new()), &info, options).unwrap();
        let mut sent = Vec::new();
        let mut frames = Vec::new();
        for k in 1..=60u64 {
            let f = proto::RgbFrame::rendered(k - 1, k * TICK_NS, (2, 1), vec![k as u8; 6]);
            // Cameras publish updates: a key frame, then only what changed (here everything).
            let update = if k == 1 {
                proto::RgbUpdate::key(&f)
            } else {
                let whole = proto::PixelRect {
                    x: 0,
                    y: 0,
                    width: 2,
                    height: 1,
                };
                proto::RgbUpdate::delta(&f, k - 2, whole)
            };
            let bytes = proto::encode(&update);
            match w.record(&keys.sensor_rgb(&o2), &bytes).unwrap() {
                Recorded::Message { kind, .. } => assert_eq!(kind, MessageKind::RgbUpdate),
                other => panic!("{other:?}"),
            }
            sent.push(bytes);
            frames.push(f);
        }
        assert_eq!(w.stats().rgb_skipped["O2"], 57);
        let bytes = w.finish(Default::default()).unwrap().into_inner();
        let (out, got) = read_bytes(&bytes);
        assert!(out.complete);
        let raw: Vec<_> = got.iter().filter(|m| m.0 == "/sensor/O2/rgb").collect();
        assert_eq!(raw.iter().map(|m| m.3.clone()).collect::<Vec<_>>(), sent);
        // The raw updates rebuild every frame, bit for bit.
        let mut rx = proto::RgbReassembler::default();
        for (m, f) in raw.iter().zip(&frames) {
            let u: proto::RgbUpdate = proto::decode(&m.3).unwrap();
            assert_eq!(&rx.apply(u).unwrap(), f);
        }
        let images: Vec<_> = got.iter().filter(|m| m.0 == "/view/O2/rgb").collect();
        assert_eq!(images.len(), 3);
        assert_eq!(images[1].1, "foxglove.RawImage");
        assert_eq!(images[1].2, 26 * TICK_NS);
        let image =
            <::foxglove::messages::RawImage as ::foxglove::Decode>::decode(images[1].3.as_slice())
                .unwrap();
        assert_eq!(image.data.as_ref(), [26u8; 6]);
        assert_eq!((image.width, image.height), (2, 1));
    }

    #[test]
    fn the_expected_view_channels_follow_the_modality_and_the_group() {
        let expected = |modality: Option<&str>, observers: usize, event_view: Option<u64>| {
            let info = SessionInfo {
                session: "v".into(),
                observers,
                modality: modality.map(String::from),
                ..SessionInfo::default()
            };
            let options = RecorderOptions {
                event_view_period_ns: event_view,
                ..RecorderOptions::default()
            };
            let w = SessionWriter::new(Cursor::new(Vec::new()), &info, options).unwrap();
            w.expected_views()
                .into_iter()
                .map(|(topic, kind)| format!("{topic} {}", kind.schema().name))
                .collect::<Vec<_>>()
        };
        let common = [
            "/view/log foxglove.Log",
            "/view/scene foxglove.SceneUpdate",
            "/view/tf foxglove.FrameTransforms",
        ];
        let with = |images: &[&str]| {
            let mut v: Vec<String> = images
                .iter()
                .chain(common.iter())
                .map(|s| s.to_string())
                .collect();
            v.sort();
            v
        };
        assert_eq!(
            expected(Some("events"), 3, Some(500_000_000)),
            with(&[
                "/view/O1/events foxglove.RawImage",
                "/view/O2/events foxglove.RawImage",
                "/view/O3/events foxglove.RawImage",
            ])
        );
        let eight = expected(Some("rgb"), 8, None);
        assert_eq!(eight.len(), 11);
        assert!(eight.contains(&"/view/O8/rgb foxglove.RawImage".to_string()));
        assert!(!eight.iter().any(|t| t.contains("events")));
        // No event pictures wanted, or a modality the writer does not know: no image channel
        // is promised (an image that comes all the same still gets its channel then).
        assert_eq!(expected(Some("events"), 3, None), with(&[]));
        assert_eq!(expected(None, 3, Some(500_000_000)), with(&[]));
    }

    #[test]
    fn a_cut_recording_reads_up_to_its_last_complete_chunk_and_never_panics() {
        let options = RecorderOptions {
            chunk_bytes: 16 << 10,
            ..RecorderOptions::default()
        };
        let (bytes, sent) = record(200, options);
        let (full, _) = read_bytes(&bytes);
        assert!(full.complete);
        let mut last = 0;
        for cut in [
            0,
            4,
            8,
            20,
            100,
            bytes.len() / 7,
            bytes.len() / 3,
            bytes.len() / 2,
            bytes.len() - 40,
            bytes.len() - 1,
        ] {
            let path = std::env::temp_dir()
                .join(format!("recorder-cut-{}-{cut}.mcap", std::process::id()));
            std::fs::write(&path, &bytes[..cut]).unwrap();
            let mut packets = Vec::new();
            let out = read_recording::<ReadError>(&path, |m| {
                if m.topic == "/sensor/O1/events" {
                    packets.push(m.data.to_vec());
                }
                Ok(())
            });
            let _ = std::fs::remove_file(&path);
            match out {
                Err(ReadError::NotMcap { .. }) => assert!(cut < 100, "cut {cut}"),
                Err(e) => panic!("cut {cut}: {e}"),
                Ok(out) => {
                    assert!(!out.complete, "cut {cut}");
                    assert!(out.problem.is_some());
                    // What was read is a prefix of what was sent.
                    assert_eq!(packets[..], sent[..packets.len()], "cut {cut}");
                    assert!(packets.len() >= last, "cut {cut}");
                    last = packets.len();
                }
            }
        }
        assert!(
            last > 100,
            "most of the file survives a cut near its end: {last}"
        );
        // Flipped bytes inside a chunk: the chunk's CRC fails, reading stops, no panic.
        let mut bad = bytes.clone();
        let mid = bad.len() / 2;
        for b in &mut bad[mid..mid + 16] {
            *b ^= 0x5a;
        }
        let (out, _) = read_bytes(&bad);
        assert!(!out.complete && out.problem.is_some());
    }

    /// Offsets of the top-level records of an intact file: (offset, opcode, body length).
    fn records_of(bytes: &[u8]) -> Vec<(usize, u8, usize)> {
        let mut out = Vec::new();
        let mut pos = 8;
        while pos + 9 <= bytes.len() - 8 {
            let len = u64::from_le_bytes(bytes[pos + 1..pos + 9].try_into().unwrap()) as usize;
            out.push((pos, bytes[pos], len));
            pos += 9 + len;
        }
        out
    }

    fn packets_of(path_bytes: &[u8]) -> (ReadOutcome, Vec<Vec<u8>>) {
        let (out, got) = read_bytes(path_bytes);
        let packets = got
            .into_iter()
            .filter(|m| m.0 == "/sensor/O1/events")
            .map(|m| m.3)
            .collect();
        (out, packets)
    }

    #[test]
    fn a_damaged_chunk_is_skipped_and_reading_resumes_at_the_next_intact_one() {
        let options = RecorderOptions {
            chunk_bytes: 16 << 10,
            ..RecorderOptions::default()
        };
        let (bytes, sent) = record(300, options);
        let (intact, all) = packets_of(&bytes);
        assert!(intact.complete, "{:?}", intact.problem);
        assert_eq!(intact.data_crc_ok, Some(true));
        assert_eq!(intact.summary_crc_ok, Some(true));
        assert_eq!(all, sent);
        let chunks: Vec<_> = records_of(&bytes)
            .into_iter()
            .filter(|r| r.1 == mcap::records::op::CHUNK)
            .collect();
        assert!(chunks.len() > 6, "{} chunks", chunks.len());
        let (at, _, len) = chunks[3];

        // 1. Bytes flipped inside one chunk: its CRC fails, the next chunk is read.
        let mut bad = bytes.clone();
        for b in &mut bad[at + 9 + len / 2..at + 9 + len / 2 + 8] {
            *b ^= 0xff;
        }
        let (out, got) = packets_of(&bad);
        assert!(!out.complete);
        assert_eq!(out.damaged.len(), 1, "{:?}", out.damaged);
        let d = &out.damaged[0];
        assert_eq!((d.from_byte, d.to_byte), (at as u64, (at + 9 + len) as u64));
        assert!(d.resumed_ns.is_some() && d.after_ns.is_some(), "{d:?}");
        assert!(d.after_ns < d.resumed_ns);
        assert_eq!(out.first_damage_ns, d.after_ns);
        assert_eq!(out.summary_crc_ok, Some(true));
        assert_eq!(out.data_crc_ok, None, "not checkable after damage");
        // Every packet read is one that was sent, in order, with one contiguous gap.
        let first = got.iter().position(|p| !sent.contains(p));
        assert_eq!(first, None);
        let lost = sent.len() - got.len();
        assert!(lost > 0 && lost < sent.len() / 3, "lost {lost}");
        let gap = got.iter().zip(&sent).position(|(a, b)| a != b).unwrap();
        assert_eq!(got[gap..], sent[gap + lost..]);
        assert!(
            out.problem
                .unwrap()
                .contains("resumed at the next intact chunk")
        );

        // 2. A garbled record length: framing is lost; the reader finds the next chunk.
        let mut garbled = bytes.clone();
        garbled[at + 1..at + 9].copy_from_slice(&u64::MAX.to_le_bytes());
        let (out, got) = packets_of(&garbled);
        assert_eq!(out.damaged.len(), 1, "{:?}", out.damaged);
        assert_eq!(out.damaged[0].from_byte, at as u64);
        assert!(out.damaged[0].to_byte > at as u64);
        assert!(got.len() < sent.len() && got.len() > sent.len() / 2);
        assert_eq!(got.last(), sent.last(), "the end of the file is read again");

        // 3. A flipped byte in the summary section: every message is read, the CRC says so.
        let summary_at = records_of(&bytes)
            .into_iter()
            .find(|r| r.1 == mcap::records::op::DATA_END)
            .map(|r| r.0 + 9 + r.2)
            .unwrap();
        let mut bad_summary = bytes.clone();
        bad_summary[summary_at + 12] ^= 0x01;
        let (out, got) = packets_of(&bad_summary);
        assert_eq!(got, sent);
        assert_eq!(out.summary_crc_ok, Some(false));
        assert!(!out.complete);
        assert!(out.problem.unwrap().contains("summary section CRC"));
    }
}
