//! The event packets of a recording that kept the event cameras' input instead
//! (`waggle run --record-events input`): each camera's sensor is rebuilt from the model and seed
//! in the session metadata and fed the recorded renders in order, which makes the packets it
//! made live, bit for bit (the sensor model is seeded and never reads a clock). Packets the
//! camera dropped under a throttle fault are dropped again, as its notices on
//! `sensor/<o>/dropped` say. A digest of what comes out is matched against the digest the
//! recorder kept of the packets it received ([`recording::UnrecordedPackets`]).

use std::collections::{BTreeMap, BTreeSet};

use anyhow::{Context, Result};
use clap::Parser;
use event_camera::{CameraConfig, EventCamera, EventSensorModel};
use node_args::SensorArgs;
use proto::scene::{IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX, MAX_OBSERVERS, observer_name};
use proto::{EventPacket, FrameChange, Modality, ObserverId, RgbReassembler, RgbUpdate};
use recording::{Decoded, SessionInfo, UnrecordedPackets};

/// The sensor arguments stored in a recording's metadata, parsed as the camera parses them.
#[derive(Parser)]
#[command(no_binary_name = true)]
struct StoredSensor {
    #[command(flatten)]
    sensor: SensorArgs,
}

/// One camera rebuilt.
struct Camera {
    camera: EventCamera,
    frames: RgbReassembler,
    /// Packets made from the last input, held until the next input (or the end) so that the
    /// camera's drop notices, published after them, have been read.
    held: Vec<EventPacket>,
    dropped: BTreeSet<u64>,
    made: UnrecordedPackets,
    /// Inputs that built on a render the recording does not hold.
    unassembled: u64,
}

/// Regenerates every camera's packets from the recorded input.
pub struct Regenerator {
    sensor: SensorArgs,
    cameras: BTreeMap<ObserverId, Camera>,
}

/// How the packets made compare with the ones the recorder received.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct Regenerated {
    pub made: UnrecordedPackets,
    /// What the recorder received live (`None`: not stored, e.g. a cut recording).
    pub received: Option<UnrecordedPackets>,
    pub unassembled: u64,
}

impl Regenerated {
    /// True when the recording says what was received and the packets made are exactly those.
    pub fn identical(&self) -> bool {
        self.unassembled == 0 && self.received == Some(self.made)
    }
}

impl Regenerator {
    /// The regenerator of a recording whose session is `info`; `None` when it keeps packets.
    pub fn of(info: &SessionInfo) -> Result<Option<Self>> {
        if !info.events_from_input {
            return Ok(None);
        }
        let stored = StoredSensor::try_parse_from(&info.sensor_args).with_context(|| {
            format!(
                "the sensor model stored in the recording ({:?})",
                info.sensor_args
            )
        })?;
        stored
            .sensor
            .check(Modality::Events)
            .context("the sensor model stored in the recording")?;
        Ok(Some(Self {
            sensor: stored.sensor,
            cameras: BTreeMap::new(),
        }))
    }

    fn camera(&mut self, o: &ObserverId) -> Result<&mut Camera> {
        if !self.cameras.contains_key(o) {
            let index = (0..MAX_OBSERVERS)
                .find(|&i| observer_name(i) == o.as_str())
                .with_context(|| format!("{o} is not an observer of this scene"))?;
            let model = self
                .sensor
                .model(Modality::Events, index)?
                .unwrap_or_else(EventSensorModel::default);
            let config = CameraConfig::paper(IMAGE_WIDTH_PX, IMAGE_HEIGHT_PX).with_model(model);
            let camera = Camera {
                camera: EventCamera::new(config).context("building the event sensor")?,
                frames: RgbReassembler::default(),
                held: Vec::new(),
                dropped: BTreeSet::new(),
                made: UnrecordedPackets::default(),
                unassembled: 0,
            };
            self.cameras.insert(o.clone(), camera);
        }
        Ok(self.cameras.get_mut(o).expect("inserted above"))
    }

    /// Feeds camera `o` one recorded input; returns the packets now released (those made from
    /// its previous input and not dropped).
    pub fn input(&mut self, o: &ObserverId, update: RgbUpdate) -> Result<Vec<EventPacket>> {
        let cam = self.camera(o)?;
        let released = cam.release();
        // A key frame is the whole render; an update says where it differs from the last one.
        let change = match update.base_seq {
            None => FrameChange::All,
            Some(_) if update.rect.area_px() == 0 => FrameChange::Nothing,
            Some(_) => FrameChange::Within(update.rect),
        };
        let frame = match cam.frames.apply(update) {
            Ok(f) => f,
            Err(_) => {
                // The recording lost the render this one builds on: nothing can follow exactly
                // until the next key frame, and the digest will say so.
                cam.unassembled += 1;
                return Ok(released);
            }
        };
        let made = cam
            .camera
            .push_frame_change(frame.stamp_ns, &frame.rgb, change)
            .with_context(|| format!("{o}: the recorded input at {} ns", frame.stamp_ns))?;
        cam.held.extend(made);
        Ok(released)
    }

    /// Camera `o` dropped its packet `seq` (its notice on `sensor/<o>/dropped`).
    pub fn dropped(&mut self, o: &ObserverId, seq: u64) -> Result<()> {
        self.camera(o)?.dropped.insert(seq);
        Ok(())
    }

    /// The packets still held, per camera (the recording has ended).
    pub fn finish(&mut self) -> BTreeMap<ObserverId, Vec<EventPacket>> {
        self.cameras
            .iter_mut()
            .map(|(o, c)| (o.clone(), c.release()))
            .collect()
    }

    /// Each camera's packets made against what the recorder received (`received`: the
    /// recorder's metadata, absent from a cut recording).
    pub fn compare(
        &self,
        received: Option<&BTreeMap<String, UnrecordedPackets>>,
    ) -> BTreeMap<String, Regenerated> {
        self.cameras
            .iter()
            .map(|(o, c)| {
                let r = Regenerated {
                    made: c.made,
                    received: received.and_then(|m| m.get(o.as_str()).copied()),
                    unassembled: c.unassembled,
                };
                (o.to_string(), r)
            })
            .collect()
    }
}

impl Camera {
    fn release(&mut self) -> Vec<EventPacket> {
        let held = std::mem::take(&mut self.held);
        let out: Vec<EventPacket> = held
            .into_iter()
            .filter(|p| !self.dropped.contains(&p.seq))
            .collect();
        for p in &out {
            self.made.packets += 1;
            self.made.events += p.len() as u64;
            self.made.digest = proto::camera::digest(self.made.digest, &proto::encode(p));
        }
        out
    }
}

/// The export's view of a recording that kept the sensors' input: each input is replaced by
/// the packets regenerated from it (on the camera's `sensor/<o>/events` topic, at their end
/// time), drop notices pass through after the packets they drop are left out, and everything
/// else passes through untouched.
pub struct ExportedEvents(pub Regenerator);

impl ExportedEvents {
    fn packets(o: &ObserverId, packets: Vec<EventPacket>) -> Vec<ros2_bag::Substituted> {
        packets
            .into_iter()
            .map(|p| {
                let t = p.end_ns;
                (format!("/sensor/{o}/events"), Decoded::EventPacket(p), t)
            })
            .collect()
    }
}

impl ros2_bag::Substitute for ExportedEvents {
    fn substitute(
        &mut self,
        topic: &str,
        msg: Decoded,
        log_time_ns: u64,
    ) -> Result<Vec<ros2_bag::Substituted>, String> {
        let key = run_eval::recording::topic_key(topic);
        match (key, msg) {
            (Some(proto::Key::CameraInput(o)), Decoded::RgbUpdate(u)) => {
                let released = self.0.input(&o, u).map_err(|e| format!("{e:#}"))?;
                Ok(Self::packets(&o, released))
            }
            (Some(proto::Key::SensorDropped(o)), Decoded::PacketDropped(d)) if d.observer == o => {
                self.0.dropped(&o, d.seq).map_err(|e| format!("{e:#}"))?;
                Ok(vec![(
                    topic.to_string(),
                    Decoded::PacketDropped(d),
                    log_time_ns,
                )])
            }
            (_, msg) => Ok(vec![(topic.to_string(), msg, log_time_ns)]),
        }
    }

    fn finish(&mut self) -> Result<Vec<ros2_bag::Substituted>, String> {
        Ok(self
            .0
            .finish()
            .into_iter()
            .flat_map(|(o, packets)| Self::packets(&o, packets))
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::{PixelRect, RgbFrame};
    use run_eval::recording::received;

    fn info(sensor_args: &[&str]) -> SessionInfo {
        SessionInfo {
            session: "t".into(),
            observers: 2,
            modality: Some("events".into()),
            sensor_args: sensor_args.iter().map(|a| a.to_string()).collect(),
            events_from_input: true,
            ..SessionInfo::default()
        }
    }

    /// Frame `k` of a bright square sliding over a grey background, and the rectangle it
    /// changed since frame `k - 1`.
    fn frame(k: u64) -> (Vec<u8>, PixelRect) {
        let (w, h) = (usize::from(IMAGE_WIDTH_PX), usize::from(IMAGE_HEIGHT_PX));
        let mut rgb = vec![90u8; w * h * 3];
        let x0 = 100 + 3 * k as usize;
        for y in 200..240 {
            for x in x0..x0 + 40 {
                rgb[(y * w + x) * 3..(y * w + x) * 3 + 3].fill(230);
            }
        }
        let rect = PixelRect {
            x: (x0 - 3) as u16,
            y: 200,
            width: 46,
            height: 40,
        };
        (rgb, rect)
    }

    #[test]
    fn recorded_input_regenerates_the_published_packets_bit_for_bit() {
        let args = [
            "--sensor-preset",
            "v2e-noisy",
            "--perturb",
            "events.shot_noise_hz=0.5",
            "--seed",
            "41",
        ];
        let mut regen = Regenerator::of(&info(&args)).unwrap().unwrap();
        let o2 = ObserverId::new("O2").unwrap();
        // The camera as the camera process builds it: observer index 1, the stored model.
        let sensor = StoredSensor::try_parse_from(args).unwrap().sensor;
        let model = sensor.model(Modality::Events, 1).unwrap().unwrap();
        let config = CameraConfig::paper(IMAGE_WIDTH_PX, IMAGE_HEIGHT_PX).with_model(model);
        let mut live = EventCamera::new(config).unwrap();
        let mut published = Vec::new();
        let mut replayed = Vec::new();
        for k in 0..60u64 {
            let (rgb, rect) = frame(k);
            let stamp_ns = (k + 1) * 10_000_000;
            let change = if k == 0 {
                FrameChange::All
            } else {
                FrameChange::Within(rect)
            };
            let made = live.push_frame_change(stamp_ns, &rgb, change).unwrap();
            let f = RgbFrame::rendered(k, stamp_ns, (IMAGE_WIDTH_PX, IMAGE_HEIGHT_PX), rgb);
            let update = match k {
                0 | 30 => RgbUpdate::key(&f),
                _ => RgbUpdate::delta(&f, k - 1, rect),
            };
            replayed.extend(regen.input(&o2, update).unwrap());
            // A throttle drops every third packet; the camera's notice follows the packet.
            for p in made {
                if p.seq % 3 == 2 {
                    regen.dropped(&o2, p.seq).unwrap();
                } else {
                    published.push(p);
                }
            }
        }
        replayed.extend(regen.finish().remove(&o2).unwrap());
        assert!(published.len() >= 10);
        assert!(published.iter().map(EventPacket::len).sum::<usize>() > 1000);
        assert_eq!(replayed, published);
        let digest = published
            .iter()
            .fold(0, |h, p| proto::camera::digest(h, &proto::encode(p)));
        let received = UnrecordedPackets {
            packets: published.len() as u64,
            events: published.iter().map(|p| p.len() as u64).sum(),
            digest,
        };
        let all = BTreeMap::from([("O2".to_string(), received)]);
        let compared = regen.compare(Some(&all));
        assert!(compared["O2"].identical(), "{compared:?}");
        // Another seed makes other packets, and the comparison says so.
        let mut other = Regenerator::of(&info(&["--sensor-preset", "v2e-noisy", "--seed", "42"]))
            .unwrap()
            .unwrap();
        for k in 0..60u64 {
            let (rgb, _) = frame(k);
            let f = RgbFrame::rendered(
                k,
                (k + 1) * 10_000_000,
                (IMAGE_WIDTH_PX, IMAGE_HEIGHT_PX),
                rgb,
            );
            other.input(&o2, RgbUpdate::key(&f)).unwrap();
        }
        other.finish();
        assert!(!other.compare(Some(&all))["O2"].identical());
    }

    #[test]
    fn a_bad_stored_sensor_or_account_is_a_clear_error() {
        let err = |r: Result<Option<Regenerator>>| format!("{:#}", r.err().unwrap());
        let e = err(Regenerator::of(&info(&["--sensor-preset", "v2e-loud"])));
        assert!(
            e.contains("v2e-loud") && e.contains("stored in the recording"),
            "{e}"
        );
        let e = err(Regenerator::of(&info(&[
            "--perturb",
            "rgb.read_noise_grey=4",
        ])));
        assert!(e.contains("rgb.read_noise_grey"), "{e}");
        let e = err(Regenerator::of(&info(&["--what"])));
        assert!(e.contains("--what"), "{e}");
        // A recording of packets needs no regeneration.
        let packets = SessionInfo {
            events_from_input: false,
            ..info(&[])
        };
        assert!(Regenerator::of(&packets).unwrap().is_none());
        let mut meta = BTreeMap::new();
        meta.insert(
            recording::RECORDER_METADATA.to_string(),
            BTreeMap::from([(recording::EVENTS_NOT_RECORDED.to_string(), "{[".to_string())]),
        );
        assert!(format!("{:#}", received(&meta).unwrap_err()).contains("malformed"));
        assert!(received(&BTreeMap::new()).unwrap().is_none());
        // An observer the scene does not have.
        let mut regen = Regenerator::of(&info(&[])).unwrap().unwrap();
        let o9 = ObserverId::new("O9").unwrap();
        let (rgb, _) = frame(0);
        let f = RgbFrame::rendered(0, 10_000_000, (IMAGE_WIDTH_PX, IMAGE_HEIGHT_PX), rgb);
        let e = format!("{:#}", regen.input(&o9, RgbUpdate::key(&f)).unwrap_err());
        assert!(e.contains("O9"), "{e}");
    }
}
