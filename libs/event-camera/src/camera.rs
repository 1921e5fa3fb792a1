//! The event camera: converter + black-input fault + 40 ms packetiser.
//!
//! The converter is the exact [`Converter`] for an ideal sensor and the [`NoisyConverter`] when
//! [`CameraConfig::noise`] has an active term; the packetiser is the same for both.
//!
//! Packets tile sim time on a fixed grid: packet k covers `(k·P, (k+1)·P]` (P = packet period),
//! independent of when the camera started, so every observer's packets line up with the 25 Hz
//! receivers. The first packet is the one following the first render (k = ⌊t_first / P⌋); packet
//! k is emitted by the first render at or after `(k+1)·P`, which is when all its events are
//! known. Empty packets are emitted like any other: quiet is not absence.
//!
//! * `valid` — the whole interval was observed (false only for a first packet that starts before
//!   the first render).
//! * `continuous` — no render was missing inside the interval (no two consecutive renders more
//!   than one render period apart across it). Events are still interpolated across such a gap,
//!   but a receiver must not treat the packet as a direct continuation.

use std::collections::VecDeque;

use proto::{EventPacket, FrameChange, PixelRect};

use crate::converter::Converter;
use crate::error::{CameraError, ConvertError};
use crate::event::{DEFAULT_THRESHOLD, Event};
use crate::noise::{EventNoise, NoisyConverter};
use crate::real_noise::RealNoiseTiler;

/// Sensor and timing configuration of one event camera.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraConfig {
    pub width: u16,
    pub height: u16,
    /// Contrast threshold C.
    pub threshold: f64,
    pub packet_period_ns: u64,
    /// Nominal time between renders; a larger step between renders marks a gap.
    pub render_period_ns: u64,
    /// Fault: every render is replaced by a black frame before conversion.
    pub black_input: bool,
    /// Sensor non-idealities (v2e-style, seeded); the default is the ideal sensor, converted by
    /// the exact [`Converter`].
    pub noise: EventNoise,
}

impl CameraConfig {
    /// The paper's sensor: C = 0.18, 40 ms packets (25 Hz) from 100 Hz renders, no fault, no
    /// noise.
    pub fn paper(width: u16, height: u16) -> Self {
        Self {
            width,
            height,
            threshold: DEFAULT_THRESHOLD,
            packet_period_ns: 40_000_000,
            render_period_ns: 10_000_000,
            black_input: false,
            noise: EventNoise::default(),
        }
    }
}

/// What a sensor is, as opposed to how it is driven: its contrast threshold and its
/// non-idealities. The default is the paper's ideal sensor (C = 0.18, no noise).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EventSensorModel {
    /// Contrast threshold C, log intensity.
    pub threshold: f64,
    pub noise: EventNoise,
}

impl Default for EventSensorModel {
    fn default() -> Self {
        Self {
            threshold: DEFAULT_THRESHOLD,
            noise: EventNoise::default(),
        }
    }
}

impl CameraConfig {
    /// This configuration with `model`'s threshold and noise.
    pub fn with_model(mut self, model: EventSensorModel) -> Self {
        self.threshold = model.threshold;
        self.noise = model.noise;
        self
    }
}

/// The converter of a camera: the exact one for an ideal sensor, else the noisy one.
#[derive(Clone)]
enum Sensor {
    Exact(Box<Converter>),
    Noisy(Box<NoisyConverter>),
}

impl Sensor {
    fn new(config: &CameraConfig) -> Result<Self, ConvertError> {
        config.noise.validate()?;
        Ok(if config.noise.is_ideal() {
            Sensor::Exact(Box::new(Converter::new(
                config.width,
                config.height,
                config.threshold,
            )?))
        } else {
            Sensor::Noisy(Box::new(NoisyConverter::new(
                config.width,
                config.height,
                config.threshold,
                &config.noise,
            )?))
        })
    }

    fn is_initialised(&self) -> bool {
        match self {
            Sensor::Exact(c) => c.is_initialised(),
            Sensor::Noisy(c) => c.is_initialised(),
        }
    }

    fn push(
        &mut self,
        stamp_ns: u64,
        rgb: &[u8],
        out: &mut Vec<Event>,
    ) -> Result<(), ConvertError> {
        match self {
            Sensor::Exact(c) => c.push(stamp_ns, rgb, out),
            Sensor::Noisy(c) => c.push(stamp_ns, rgb, out),
        }
    }

    fn push_region(
        &mut self,
        stamp_ns: u64,
        rgb: &[u8],
        region: Option<PixelRect>,
        out: &mut Vec<Event>,
    ) -> Result<(), ConvertError> {
        match self {
            Sensor::Exact(c) => c.push_region(stamp_ns, rgb, region, out),
            Sensor::Noisy(c) => c.push_region(stamp_ns, rgb, region, out),
        }
    }
}

/// One synthetic event camera producing [`EventPacket`]s from renders.
#[derive(Clone)]
pub struct EventCamera {
    config: CameraConfig,
    converter: Sensor,
    /// All-zero frame fed instead of the render under the black-input fault.
    black: Vec<u8>,
    /// Whether the converter's last input was the black frame.
    fed_black: bool,
    /// Converted events not yet packed, in time order.
    pending: Vec<Event>,
    next_seq: u64,
    /// Grid index k of the next packet, once the first render has arrived.
    next_packet: Option<u64>,
    first_stamp_ns: u64,
    last_stamp_ns: u64,
    /// Render gaps `(previous render, render)` that may still overlap unsent packets.
    gaps: VecDeque<(u64, u64)>,
    /// A real recording's background laid over the converted events (None: none).
    real_noise: Option<RealNoiseTiler>,
}

impl std::fmt::Debug for EventCamera {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EventCamera")
            .field("config", &self.config)
            .field("next_seq", &self.next_seq)
            .field("pending_events", &self.pending.len())
            .finish_non_exhaustive()
    }
}

impl EventCamera {
    pub fn new(config: CameraConfig) -> Result<Self, CameraError> {
        if config.packet_period_ns == 0 || config.packet_period_ns > u64::from(u32::MAX) {
            return Err(CameraError::BadPacketPeriod(config.packet_period_ns));
        }
        if config.render_period_ns == 0 {
            return Err(CameraError::BadRenderPeriod);
        }
        let converter = Sensor::new(&config)?;
        let pixels = usize::from(config.width) * usize::from(config.height);
        Ok(Self {
            config,
            converter,
            black: vec![0; 3 * pixels],
            fed_black: false,
            pending: Vec::new(),
            next_seq: 0,
            next_packet: None,
            first_stamp_ns: 0,
            last_stamp_ns: 0,
            gaps: VecDeque::new(),
            real_noise: None,
        })
    }

    /// This camera with a real recording's background added to what it converts, from its
    /// first render on ([`crate::real_noise`]).
    pub fn with_real_noise(mut self, tiler: RealNoiseTiler) -> Self {
        self.real_noise = Some(tiler);
        self
    }

    pub fn config(&self) -> &CameraConfig {
        &self.config
    }

    /// Switches the black-input fault on or off for subsequent renders.
    pub fn set_black_input(&mut self, black: bool) {
        self.config.black_input = black;
    }

    /// Sequence number the next packet will carry.
    pub fn next_seq(&self) -> u64 {
        self.next_seq
    }

    /// Feeds the render made at `stamp_ns` and returns the packets it completes (usually none
    /// or one; several after a render gap longer than a packet). On error nothing changes.
    pub fn push_frame(
        &mut self,
        stamp_ns: u64,
        rgb: &[u8],
    ) -> Result<Vec<EventPacket>, CameraError> {
        self.push_frame_change(stamp_ns, rgb, FrameChange::All)
    }

    /// [`EventCamera::push_frame`] for a render known to differ from the previous render only as
    /// `change` says: only changed pixels are converted, with exactly the same packets.
    pub fn push_frame_change(
        &mut self,
        stamp_ns: u64,
        rgb: &[u8],
        change: FrameChange,
    ) -> Result<Vec<EventPacket>, CameraError> {
        ConvertError::check_frame(rgb, self.config.width, self.config.height)?;
        // The change is relative to the previous *render*; the converter saw a black frame
        // instead while the fault was on, so the first frame after it is converted whole.
        let region = match change {
            _ if self.config.black_input || self.fed_black || !self.converter.is_initialised() => {
                None
            }
            FrameChange::All => None,
            FrameChange::Within(r) => Some(Some(r)),
            FrameChange::Nothing => Some(None),
        };
        let converted_from = self.pending.len();
        match region {
            None if self.config.black_input => {
                self.converter
                    .push(stamp_ns, &self.black, &mut self.pending)?;
            }
            None => self.converter.push(stamp_ns, rgb, &mut self.pending)?,
            Some(r) => self
                .converter
                .push_region(stamp_ns, rgb, r, &mut self.pending)?,
        }
        self.fed_black = self.config.black_input;
        if let Some(tiler) = &mut self.real_noise {
            // The sensor's own noise goes on under a black input; the converter's events come
            // first among those of one instant (a stable sort).
            tiler.start(stamp_ns);
            tiler.fill(stamp_ns, &mut self.pending);
            if self.pending.len() > converted_from {
                self.pending[converted_from..].sort_by_key(|e| e.t_ns);
            }
        }
        let period = self.config.packet_period_ns;
        let Some(mut k) = self.next_packet else {
            self.first_stamp_ns = stamp_ns;
            self.last_stamp_ns = stamp_ns;
            self.next_packet = Some(stamp_ns / period);
            return Ok(Vec::new());
        };
        if stamp_ns - self.last_stamp_ns > self.config.render_period_ns {
            self.gaps.push_back((self.last_stamp_ns, stamp_ns));
        }
        self.last_stamp_ns = stamp_ns;

        let mut packets = Vec::new();
        while (k + 1).saturating_mul(period) <= stamp_ns {
            packets.push(self.pack(k * period, (k + 1) * period));
            k += 1;
        }
        self.next_packet = Some(k);
        Ok(packets)
    }

    fn pack(&mut self, start_ns: u64, end_ns: u64) -> EventPacket {
        let count = self.pending.partition_point(|e| e.t_ns <= end_ns);
        let events = &self.pending[..count];
        let continuous = !self.gaps.iter().any(|&(a, b)| a < end_ns && start_ns < b);
        while self.gaps.front().is_some_and(|&(_, b)| b <= end_ns) {
            self.gaps.pop_front();
        }
        let packet = EventPacket {
            seq: self.next_seq,
            start_ns,
            end_ns,
            width: self.config.width,
            height: self.config.height,
            valid: self.first_stamp_ns <= start_ns,
            continuous,
            xs: events.iter().map(|e| e.x).collect(),
            ys: events.iter().map(|e| e.y).collect(),
            // Events lie in (start, end] and the period fits u32 (checked in `new`).
            dt_ns: events.iter().map(|e| (e.t_ns - start_ns) as u32).collect(),
            on_bits: EventPacket::pack_polarities(events.iter().map(|e| e.polarity)),
        };
        self.pending.drain(..count);
        self.next_seq += 1;
        packet
    }
}
