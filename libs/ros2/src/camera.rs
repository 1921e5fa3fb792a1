//! A live event camera's messages cut into the receivers' packets: each
//! `event_camera_msgs/msg/EventPacket` ([`PacketDecoder`]) decoded, its events moved into the
//! reference camera (`event_camera::calibration`) and cut into 40 ms packets
//! (`event_camera::packets`), a packet handed out as soon as an event or the stream's clock has
//! passed its end. `waggle observe` feeds them to a receiver; a camera process whose source is
//! a ROS 2 camera publishes them on Waggle's bus.

use std::path::{Path, PathBuf};

use event_camera::Event;
use event_camera::calibration::{EventRemap, Intrinsics};
use event_camera::packets::Packetizer;
use proto::EventPacket;

use crate::ingest::PacketDecoder;

/// One camera's stream, from messages to packets.
#[derive(Debug)]
pub struct CameraPackets {
    decoder: PacketDecoder,
    calibration: Option<PathBuf>,
    /// Decided at the first message (its sensor size): the remap, if any.
    remap: Option<Option<EventRemap>>,
    packetizer: Packetizer,
    events: u64,
    outside: u64,
    last_ns: u64,
    scratch: Vec<Event>,
}

impl CameraPackets {
    /// A stream remapped through `calibration` (else: a camera of another size than the
    /// reference is taken to have its field of view).
    pub fn new(calibration: Option<&Path>) -> Self {
        Self {
            decoder: PacketDecoder::default(),
            calibration: calibration.map(Path::to_path_buf),
            remap: None,
            packetizer: Packetizer::new(),
            events: 0,
            outside: 0,
            last_ns: 0,
            scratch: Vec::new(),
        }
    }

    /// Decodes one message's CDR bytes and hands every packet it completes to `out`; a
    /// refused message hands nothing and says why.
    pub fn take(&mut self, cdr: &[u8], mut out: impl FnMut(EventPacket)) -> Result<(), String> {
        self.scratch.clear();
        self.decoder.push(cdr, &mut self.scratch)?;
        if self.remap.is_none() {
            let cam = Intrinsics::of_recording(self.calibration.as_deref(), self.decoder.size())
                .map_err(|e| chain(&e))?;
            self.remap = Some(cam.as_ref().map(EventRemap::new));
        }
        self.events += self.scratch.len() as u64;
        if let Some(remap) = self.remap.as_ref().and_then(Option::as_ref) {
            let before = self.scratch.len();
            self.scratch.retain_mut(|e| match remap.map(e.x, e.y) {
                Some((x, y)) => {
                    (e.x, e.y) = (x, y);
                    true
                }
                None => false,
            });
            self.outside += (before - self.scratch.len()) as u64;
        }
        for e in &self.scratch {
            self.last_ns = self.last_ns.max(e.t_ns);
            self.packetizer.push(e, &mut out);
        }
        if let Some(now_ns) = self.decoder.stream_time_ns() {
            self.packetizer.advance_to(now_ns, &mut out);
        }
        Ok(())
    }

    /// Hands out every packet up to the one holding the last event plus `tail_ns`; returns
    /// that end, ns.
    pub fn finish(&mut self, tail_ns: u64, out: impl FnMut(EventPacket)) -> u64 {
        let end_ns = self.last_ns + tail_ns;
        self.packetizer.finish(end_ns, out);
        end_ns
    }

    /// Hands out every packet up to the one holding the later of the last event and the
    /// stream's clock: all the stream has said (a camera that has left).
    pub fn finish_stream(&mut self, out: impl FnMut(EventPacket)) {
        let now_ns = self.decoder.stream_time_ns().unwrap_or(0);
        self.finish(now_ns.saturating_sub(self.last_ns), out);
    }

    /// The sensor's size, once a message has stated it.
    pub fn size(&self) -> Option<(u16, u16)> {
        self.decoder.size()
    }

    /// Whether events are remapped into the reference camera.
    pub fn remapped(&self) -> bool {
        self.remap.as_ref().is_some_and(Option::is_some)
    }

    /// Events decoded (before any remap).
    pub fn events(&self) -> u64 {
        self.events
    }

    /// Events outside the reference camera's field, dropped.
    pub fn outside(&self) -> u64 {
        self.outside
    }

    /// Events that came after a later packet had been handed out, dropped.
    pub fn late(&self) -> u64 {
        self.packetizer.late()
    }

    /// Packets handed out.
    pub fn packets(&self) -> u64 {
        self.packetizer.packets()
    }
}

/// An error and its causes, as one line.
fn chain(e: &dyn std::error::Error) -> String {
    let mut out = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        out.push_str(": ");
        out.push_str(&c.to_string());
        cause = c.source();
    }
    out
}
