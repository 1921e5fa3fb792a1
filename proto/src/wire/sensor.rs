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

    /// The tick the packet belongs to: the one its interval ends in, `end_ns / TICK_NS`.
    pub fn tick(&self) -> u64 {
        self.end_ns / crate::TICK_NS
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
        let polarities = polarities.into_iter();
        let mut bits = Vec::with_capacity(polarities.size_hint().0.div_ceil(8));
        // A byte is assembled in a register and pushed whole: the polarity is a coin flip to
        // the branch predictor (noise), and a push per event cost 3.5 % of a noisy trial.
        let (mut byte, mut n) = (0u8, 0usize);
        for p in polarities {
            byte |= u8::from(p == Polarity::On) << (n % 8);
            n += 1;
            if n % 8 == 0 {
                bits.push(byte);
                byte = 0;
            }
        }
        if n % 8 != 0 {
            bits.push(byte);
        }
        bits
    }

    /// Writes into `out` this packet with only the events `keep` selects (every other field
    /// copied, order kept; `keep(i)` is asked once per event, in order) and returns how many
    /// it kept. `out`'s buffers are reused: the one way a filter passes a packet on.
    pub fn select_into(&self, out: &mut EventPacket, mut keep: impl FnMut(usize) -> bool) -> usize {
        out.seq = self.seq;
        out.start_ns = self.start_ns;
        out.end_ns = self.end_ns;
        out.width = self.width;
        out.height = self.height;
        out.valid = self.valid;
        out.continuous = self.continuous;
        // Two passes: the kept events' indices first, each written at the next free slot of
        // `out.dt_ns` (as scratch) with the slot advancing only when kept (no branch on `keep`,
        // which a noise filter answers at random), then a copy of only those events. A noise
        // filter keeps ≈ 1 % of a noisy packet, and copying every event at a branch-free slot
        // cost ≈ 5 ns per event (the bench `noise_front_end`). Indices fit in u32: a decoded
        // packet is at most 256 MB (`codec`'s limit), far below 2³² events.
        let n = self.len();
        out.dt_ns.resize(n, 0);
        let mut kept = 0usize;
        for i in 0..n {
            out.dt_ns[kept] = i as u32;
            kept += usize::from(keep(i));
        }
        out.xs.resize(kept, 0);
        out.ys.resize(kept, 0);
        out.on_bits.clear();
        out.on_bits.resize(kept.div_ceil(8), 0);
        for k in 0..kept {
            // Slot k holds its event's index until it gets that event's time: read before write.
            let i = out.dt_ns[k] as usize;
            out.xs[k] = self.xs[i];
            out.ys[k] = self.ys[i];
            out.dt_ns[k] = self.dt_ns[i];
            let on = (self.on_bits[i / 8] >> (i % 8)) & 1;
            out.on_bits[k / 8] |= on << (k % 8);
        }
        out.dt_ns.truncate(kept);
        kept
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

impl RgbFrame {
    /// Frame `seq` rendered at `stamp_ns`, `(width, height)` pixels: trustworthy and following
    /// the frame before it (`valid`, `continuous`).
    pub fn rendered(seq: u64, stamp_ns: u64, (width, height): (u16, u16), rgb: Vec<u8>) -> Self {
        Self {
            seq,
            stamp_ns,
            width,
            height,
            valid: true,
            continuous: true,
            rgb,
        }
    }

    /// The tick the frame belongs to: the one it was rendered at, `stamp_ns / TICK_NS`.
    pub fn tick(&self) -> u64 {
        self.stamp_ns / crate::TICK_NS
    }
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

/// A pixel rectangle of an image, top row first (as frames are stored).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct PixelRect {
    pub x: u16,
    pub y: u16,
    pub width: u16,
    pub height: u16,
}

impl PixelRect {
    pub fn area_px(self) -> usize {
        usize::from(self.width) * usize::from(self.height)
    }

    /// Whether the rectangle lies inside a `width`×`height` image.
    pub fn fits(self, width: u16, height: u16) -> bool {
        u32::from(self.x) + u32::from(self.width) <= u32::from(width)
            && u32::from(self.y) + u32::from(self.height) <= u32::from(height)
    }
}

/// What an RGB camera publishes on `sensor/<o>/rgb`: a whole frame (a *key* frame), or only the
/// pixels of `rect` when every other pixel equals the frame it published just before.
///
/// The reconstruction contract: an update with `base_seq: Some(b)` applies only to frame `b`
/// itself; a receiver holding another frame (it missed one) cannot use it and waits for the
/// next key frame. Cameras send a key frame first, after any frame they did not publish
/// (throttled), whenever the whole view may have changed, and at least every
/// [`RgbUpdate::KEY_EVERY`] frames, so a lost update costs at most that many frames.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct RgbUpdate {
    pub seq: u64,
    pub stamp_ns: u64,
    pub width: u16,
    pub height: u16,
    pub valid: bool,
    pub continuous: bool,
    /// `None`: a key frame (`rect` is the whole image).
    pub base_seq: Option<u64>,
    pub rect: PixelRect,
    /// `rect`'s pixels, row-major, 3 bytes per pixel, top row first.
    #[serde(with = "crate::codec::bulk_bytes")]
    pub rgb: Vec<u8>,
}

impl RgbUpdate {
    /// The longest run of frames between key frames.
    pub const KEY_EVERY: u64 = 25;

    /// The whole of `frame`.
    pub fn key(frame: &RgbFrame) -> Self {
        let whole = PixelRect {
            x: 0,
            y: 0,
            width: frame.width,
            height: frame.height,
        };
        Self::of(frame, None, whole, frame.rgb.clone())
    }

    /// `rect` of `frame`, which equals frame `base_seq` everywhere else. `rect` must fit.
    pub fn delta(frame: &RgbFrame, base_seq: u64, rect: PixelRect) -> Self {
        let mut rgb = Vec::with_capacity(rect.area_px() * 3);
        let row_bytes = usize::from(frame.width) * 3;
        for y in usize::from(rect.y)..usize::from(rect.y) + usize::from(rect.height) {
            let start = y * row_bytes + usize::from(rect.x) * 3;
            rgb.extend_from_slice(&frame.rgb[start..start + usize::from(rect.width) * 3]);
        }
        Self::of(frame, Some(base_seq), rect, rgb)
    }

    /// `frame`'s header with the given pixels.
    fn of(frame: &RgbFrame, base_seq: Option<u64>, rect: PixelRect, rgb: Vec<u8>) -> Self {
        Self {
            seq: frame.seq,
            stamp_ns: frame.stamp_ns,
            width: frame.width,
            height: frame.height,
            valid: frame.valid,
            continuous: frame.continuous,
            base_seq,
            rect,
            rgb,
        }
    }
}

impl Validate for RgbUpdate {
    fn validate(&self) -> Result<(), String> {
        if !self.rect.fits(self.width, self.height) {
            return Err(format!(
                "rgb update {}: rect {:?} outside {}x{}",
                self.seq, self.rect, self.width, self.height
            ));
        }
        if self.rgb.len() != self.rect.area_px() * 3 {
            return Err(format!(
                "rgb update {}: {} bytes for a {}x{} rect",
                self.seq,
                self.rgb.len(),
                self.rect.width,
                self.rect.height
            ));
        }
        match self.base_seq {
            None if self.rect.area_px() != usize::from(self.width) * usize::from(self.height) => {
                Err(format!(
                    "rgb key frame {} does not cover the image",
                    self.seq
                ))
            }
            Some(b) if b >= self.seq => {
                Err(format!("rgb update {} builds on later frame {b}", self.seq))
            }
            _ => Ok(()),
        }
    }
}

/// Rebuilds one camera's frames from its [`RgbUpdate`]s (the receiving half of the contract).
#[derive(Debug, Clone, Default)]
pub struct RgbReassembler {
    held: Option<RgbFrame>,
}

/// An update that does not apply to the frame held.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("rgb update {seq} builds on frame {base}, but the frame held is {held:?}")]
pub struct Unassembled {
    pub seq: u64,
    pub base: u64,
    pub held: Option<u64>,
}

impl RgbReassembler {
    /// The frame `update` describes; on error nothing changes (the update is unusable).
    pub fn apply(&mut self, update: RgbUpdate) -> Result<RgbFrame, Unassembled> {
        let Some(base) = update.base_seq else {
            let frame = RgbFrame {
                seq: update.seq,
                stamp_ns: update.stamp_ns,
                width: update.width,
                height: update.height,
                valid: update.valid,
                continuous: update.continuous,
                rgb: update.rgb,
            };
            self.held = Some(frame.clone());
            return Ok(frame);
        };
        let held = match self.held.as_mut() {
            Some(h) if h.seq == base && (h.width, h.height) == (update.width, update.height) => h,
            other => {
                return Err(Unassembled {
                    seq: update.seq,
                    base,
                    held: other.map(|h| h.seq),
                });
            }
        };
        let (r, row_bytes) = (update.rect, usize::from(update.width) * 3);
        let rect_row = usize::from(r.width) * 3;
        if rect_row > 0 {
            for (k, src) in update.rgb.chunks_exact(rect_row).enumerate() {
                let start = (usize::from(r.y) + k) * row_bytes + usize::from(r.x) * 3;
                held.rgb[start..start + rect_row].copy_from_slice(src);
            }
        }
        held.seq = update.seq;
        held.stamp_ns = update.stamp_ns;
        held.valid = update.valid;
        held.continuous = update.continuous;
        Ok(held.clone())
    }
}

/// How a camera's frame differs from its previous frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum FrameChange {
    /// Bit-identical.
    Nothing,
    /// Pixels outside the rectangle are bit-identical.
    Within(PixelRect),
    /// Any pixel may differ.
    All,
}

/// A camera's notice that it dropped its packet of `tick` (`sensor/<o>/dropped`): a throttled
/// publisher knows which packets it did not send, and says so.
///
/// It lets the observer judge the packet missing from what arrived, in whatever order and after
/// whatever delay the transport delivers, instead of from a wall-clock wait (docs/DESIGN.md §3):
/// with it, no fault of the launcher leaves a packet's fate to a grace period.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct PacketDropped {
    pub observer: crate::keys::ObserverId,
    /// The tick whose packet was dropped (an RGB frame's `stamp_ns / TICK_NS`, an event
    /// packet's `end_ns / TICK_NS`).
    pub tick: u64,
    /// The dropped packet's sequence number.
    pub seq: u64,
}

impl Validate for PacketDropped {
    fn validate(&self) -> Result<(), String> {
        if self.tick == 0 {
            return Err(format!(
                "{}: tick 0 has no sensor packet to drop",
                self.observer
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod rgb_update_tests {
    use super::*;
    use crate::codec::{decode, encode};

    fn frame(seq: u64, fill: impl Fn(usize) -> u8) -> RgbFrame {
        RgbFrame {
            seq,
            stamp_ns: seq * 40,
            width: 7,
            height: 5,
            valid: true,
            continuous: true,
            rgb: (0..7 * 5 * 3).map(fill).collect(),
        }
    }

    #[test]
    fn key_and_delta_updates_rebuild_every_frame_exactly() {
        let f0 = frame(0, |i| i as u8);
        let mut f1 = f0.clone();
        f1.seq = 1;
        f1.stamp_ns = 40;
        let rect = PixelRect {
            x: 2,
            y: 1,
            width: 3,
            height: 2,
        };
        for y in 1..3 {
            for x in 2..5 {
                let i = (y * 7 + x) * 3;
                f1.rgb[i..i + 3].copy_from_slice(&[200, 201, 202]);
            }
        }
        let mut f2 = f1.clone();
        f2.seq = 2;
        let mut r = RgbReassembler::default();
        let wire = |u: &RgbUpdate| decode::<RgbUpdate>(&encode(u)).unwrap();
        assert_eq!(r.apply(wire(&RgbUpdate::key(&f0))), Ok(f0.clone()));
        assert_eq!(
            r.apply(wire(&RgbUpdate::delta(&f1, 0, rect))),
            Ok(f1.clone())
        );
        let nothing = PixelRect {
            x: 0,
            y: 0,
            width: 0,
            height: 0,
        };
        assert_eq!(r.apply(wire(&RgbUpdate::delta(&f2, 1, nothing))), Ok(f2));
    }

    #[test]
    fn an_update_on_a_missed_frame_is_unusable_until_the_next_key_frame() {
        let f0 = frame(0, |_| 1);
        let f3 = frame(3, |_| 3);
        let mut r = RgbReassembler::default();
        let whole = PixelRect {
            x: 0,
            y: 0,
            width: 7,
            height: 5,
        };
        assert!(r.apply(RgbUpdate::delta(&f3, 2, whole)).is_err());
        r.apply(RgbUpdate::key(&f0)).unwrap();
        let err = r.apply(RgbUpdate::delta(&f3, 2, whole)).unwrap_err();
        assert_eq!(err.held, Some(0));
        assert_eq!(r.apply(RgbUpdate::key(&f3)), Ok(f3));
    }

    #[test]
    fn inconsistent_updates_are_rejected_by_the_decoder() {
        let f = frame(4, |_| 9);
        let mut bad = RgbUpdate::delta(
            &f,
            3,
            PixelRect {
                x: 5,
                y: 0,
                width: 3,
                height: 1,
            },
        );
        assert!(decode::<RgbUpdate>(&encode(&bad)).is_err(), "rect outside");
        bad.rect.x = 0;
        bad.rgb.pop();
        assert!(decode::<RgbUpdate>(&encode(&bad)).is_err(), "short pixels");
        let mut key = RgbUpdate::key(&f);
        key.rect.width = 6;
        key.rgb.truncate(6 * 5 * 3);
        assert!(
            decode::<RgbUpdate>(&encode(&key)).is_err(),
            "partial key frame"
        );
        let later = RgbUpdate::delta(
            &f,
            4,
            PixelRect {
                x: 0,
                y: 0,
                width: 0,
                height: 0,
            },
        );
        assert!(
            decode::<RgbUpdate>(&encode(&later)).is_err(),
            "base not earlier"
        );
    }
}
