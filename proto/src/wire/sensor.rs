//! Sensor payloads: synthetic event packets and RGB frames.

use serde::{Deserialize, Serialize};

use crate::codec::Validate;

/// Event polarity: ON for a rise in log intensity, OFF for a fall.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Polarity {
    On,
    Off,
}

impl Polarity {
    /// +1 for ON, −1 for OFF.
    pub fn sign(self) -> i8 {
        match self {
            Polarity::On => 1,
            Polarity::Off => -1,
        }
    }
}

/// One 40 ms packet of synthetic events for one observer, struct-of-arrays.
///
/// Emitted for every tick, including empty ones: silence must be distinguishable from absence.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct EventPacket {
    /// Packet sequence number, contiguous from 0 for one camera.
    pub seq: u64,
    /// Start watermark (exclusive), sim nanoseconds.
    pub start_ns: u64,
    /// End watermark (inclusive), sim nanoseconds.
    pub end_ns: u64,
    pub width: u16,
    pub height: u16,
    /// False when the sensor could not produce trustworthy data for this interval.
    pub valid: bool,
    /// False when this packet does not directly follow the previous one from the same source.
    pub continuous: bool,
    pub xs: Vec<u16>,
    pub ys: Vec<u16>,
    /// Event times as offsets from `start_ns`, nanoseconds.
    pub dt_ns: Vec<u32>,
    /// Polarity bits, one per event, packed LSB first; 1 = ON.
    #[serde(with = "crate::codec::bulk_bytes")]
    pub on_bits: Vec<u8>,
}

impl EventPacket {
    /// Number of events in the packet.
    pub fn len(&self) -> usize {
        self.xs.len()
    }

    /// True when the packet holds no events.
    pub fn is_empty(&self) -> bool {
        self.xs.is_empty()
    }

    /// Polarity of event `i`.
    pub fn polarity(&self, i: usize) -> Polarity {
        if self.on_bits[i / 8] >> (i % 8) & 1 == 1 {
            Polarity::On
        } else {
            Polarity::Off
        }
    }

    /// Absolute sim time of event `i`.
    pub fn t_ns(&self, i: usize) -> u64 {
        self.start_ns + u64::from(self.dt_ns[i])
    }

    /// Packs polarities into the bit layout of `on_bits`.
    pub fn pack_polarities(polarities: impl IntoIterator<Item = Polarity>) -> Vec<u8> {
        let mut bits = Vec::new();
        for (i, p) in polarities.into_iter().enumerate() {
            if i % 8 == 0 {
                bits.push(0);
            }
            if p == Polarity::On {
                *bits.last_mut().expect("pushed above") |= 1 << (i % 8);
            }
        }
        bits
    }

    /// A valid packet that continues its stream: sequence `seq`, covering `(start_ns, end_ns]`
    /// of a `width`×`height` sensor, holding `events` as `(x, y, dt_ns, polarity)` in order.
    /// The one way tests and tools build a packet by hand.
    pub fn from_events(
        seq: u64,
        (start_ns, end_ns): (u64, u64),
        (width, height): (u16, u16),
        events: &[(u16, u16, u32, Polarity)],
    ) -> Self {
        Self {
            seq,
            start_ns,
            end_ns,
            width,
            height,
            valid: true,
            continuous: true,
            xs: events.iter().map(|e| e.0).collect(),
            ys: events.iter().map(|e| e.1).collect(),
            dt_ns: events.iter().map(|e| e.2).collect(),
            on_bits: Self::pack_polarities(events.iter().map(|e| e.3)),
        }
    }
}

impl Validate for EventPacket {
    fn validate(&self) -> Result<(), String> {
        let n = self.xs.len();
        if self.ys.len() != n || self.dt_ns.len() != n {
            return Err(format!(
                "event packet {}: array lengths differ (xs {}, ys {}, dt_ns {})",
                self.seq,
                n,
                self.ys.len(),
                self.dt_ns.len()
            ));
        }
        if self.on_bits.len() != n.div_ceil(8) {
            return Err(format!(
                "event packet {}: {} polarity bytes for {n} events",
                self.seq,
                self.on_bits.len()
            ));
        }
        if self.end_ns < self.start_ns {
            return Err(format!(
                "event packet {}: end watermark before start",
                self.seq
            ));
        }
        let span = self.end_ns - self.start_ns;
        if let Some(i) = (0..n).find(|&i| {
            self.xs[i] >= self.width || self.ys[i] >= self.height || u64::from(self.dt_ns[i]) > span
        }) {
            return Err(format!(
                "event packet {}: event {i} at ({}, {}, +{} ns) outside {}x{} / {} ns",
                self.seq, self.xs[i], self.ys[i], self.dt_ns[i], self.width, self.height, span
            ));
        }
        Ok(())
    }
}

/// One RGB camera frame, row-major, 3 bytes per pixel, top row first.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct RgbFrame {
    pub seq: u64,
    pub stamp_ns: u64,
    pub width: u16,
    pub height: u16,
    pub valid: bool,
    pub continuous: bool,
    #[serde(with = "crate::codec::bulk_bytes")]
    pub rgb: Vec<u8>,
}

impl Validate for RgbFrame {
    fn validate(&self) -> Result<(), String> {
        let want = usize::from(self.width) * usize::from(self.height) * 3;
        if self.rgb.len() != want {
            return Err(format!(
                "rgb frame {}: {} bytes for {}x{} (want {want})",
                self.seq,
                self.rgb.len(),
                self.width,
                self.height
            ));
        }
        Ok(())
    }
}
