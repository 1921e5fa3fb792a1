//! The event receiver: one observer's packets in, tokens and released frames out.
//!
//! Per 40 ms packet, stamped with its end watermark:
//! 1. [`DeliveryMonitor`] — malformed packets are rejected (counted by reason) and interrupt;
//!    missing, invalid or non-continuous packets interrupt.
//! 2. [`NoiseFilter`] — the noise front end: events without correlated neighbours (shot noise,
//!    leak, hot pixels) are removed; always on.
//! 3. [`SupportTracker`] — broad activity interrupts; a supported one-sided window holds the
//!    track in doubt (dropped unless located again); otherwise the estimate is located from
//!    this packet's support or held (quiet, sparse tails).
//! 4. [`Acquisition`] — the NULL gate: a closed moving path observed (in the image the unturned
//!    camera would have made), and event-supported tracking no older than the 20 s lease.
//! 5. [`Decoder`] — the shared segmenter (20 px anchor, 3 s NULL, event match settings) and the
//!    17-token frame parser.
//!
//! An interruption drops the target, the acquisition and any incomplete frame; the decoder
//! reports one `Unknown`. Until the first localisation nothing is fed to the decoder: silence
//! before any target was seen produces no tokens at all.

use std::collections::BTreeMap;

use proto::{DecodeError, EventPacket, ReleasedFrame, Token};

use crate::events::acquisition::{Acquisition, AcquisitionConfig, AcquisitionEvent};
use crate::events::denoise::{DenoiseConfig, DenoiseCounts, NoiseFilter};
use crate::events::ego_motion::EgoMotionFilter;
use crate::events::error::EventReceiverError;
use crate::events::health::{Delivery, DeliveryMonitor, Discontinuity, PacketRejection};
use crate::events::support::{Centre, Window};
use crate::events::tracker::{EventTrackerConfig, Observation, SupportTracker, TrackFault};
use proto::decoder::{DecodeStep, Decoder};
use proto::segmenter::{Sample, SegmentToken, SegmenterConfig, TokenCause};
use proto::stabilise::{predicted_px, stabilised_px};

/// Everything an event receiver is configured with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EventReceiverConfig {
    pub width: u16,
    pub height: u16,
    /// Length of one packet's interval (the receiver steps once per packet).
    pub packet_period_ns: u64,
    /// The noise front end.
    pub denoise: DenoiseConfig,
    pub tracker: EventTrackerConfig,
    pub acquisition: AcquisitionConfig,
    pub segmenter: SegmenterConfig,
}

impl EventReceiverConfig {
    /// The paper's event receiver: 640×480 sensor, 40 ms packets (25 Hz), 20 px anchor, 3 s
    /// NULL, 20 s lease, event match settings.
    pub fn paper() -> Self {
        Self {
            width: proto::scene::IMAGE_WIDTH_PX,
            height: proto::scene::IMAGE_HEIGHT_PX,
            packet_period_ns: 40_000_000,
            denoise: DenoiseConfig::receiver(),
            tracker: EventTrackerConfig::paper(),
            acquisition: AcquisitionConfig::paper(),
            segmenter: SegmenterConfig::events(),
        }
    }

    /// Rejects settings no receiver could run with.
    pub fn validate(&self) -> Result<(), EventReceiverError> {
        if self.width == 0 || self.height == 0 {
            return Err(EventReceiverError::BadSetting {
                setting: "width / height",
                reason: format!("sensor {}x{} has no pixels", self.width, self.height),
            });
        }
        if self.packet_period_ns == 0 || self.packet_period_ns > self.segmenter.max_gap_ns {
            return Err(EventReceiverError::BadSetting {
                setting: "packet_period_ns",
                reason: format!(
                    "{} ns must be positive and within the segmenter's {} ns gap limit",
                    self.packet_period_ns, self.segmenter.max_gap_ns
                ),
            });
        }
        self.denoise.validate()?;
        self.tracker.validate()?;
        self.acquisition.validate()?;
        self.segmenter.validate()?;
        Ok(())
    }
}

impl Default for EventReceiverConfig {
    fn default() -> Self {
        Self::paper()
    }
}

/// Why tracking was interrupted. Counted per cause.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum EventInterruptCause {
    /// A malformed packet.
    Rejected(PacketRejection),
    SequenceGap,
    Restart,
    Invalid,
    NotContinuous,
    BroadActivity,
    OneSidedPolarity,
    /// A track located once and then never again ([`TrackFault::Unconfirmed`]).
    Unconfirmed,
    /// Reported by the caller ([`EventReceiver::interrupt`]): a lost publisher, a fault.
    External,
}

impl From<Discontinuity> for EventInterruptCause {
    fn from(d: Discontinuity) -> Self {
        match d {
            Discontinuity::SequenceGap { .. } => EventInterruptCause::SequenceGap,
            Discontinuity::Restart => EventInterruptCause::Restart,
            Discontinuity::Invalid => EventInterruptCause::Invalid,
            Discontinuity::NotContinuous => EventInterruptCause::NotContinuous,
        }
    }
}

impl From<TrackFault> for EventInterruptCause {
    fn from(f: TrackFault) -> Self {
        match f {
            TrackFault::BroadActivity { .. } => EventInterruptCause::BroadActivity,
            TrackFault::OneSidedPolarity { .. } => EventInterruptCause::OneSidedPolarity,
            TrackFault::Unconfirmed { .. } => EventInterruptCause::Unconfirmed,
        }
    }
}

/// One receiver step of a trajectory.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EventTrackStep {
    pub stamp_ns: u64,
    /// The estimate fed to the segmenter.
    pub point_px: [f64; 2],
    /// Located from this packet's own support (false: held through quiet or a sparse tail).
    pub supported: bool,
}

/// The trajectory behind one decoded symbol: every estimate fed to the segmenter from the
/// previous NULL confirmation to the one that classified it.
#[derive(Debug, Clone, PartialEq)]
pub struct EventSymbolTrajectory {
    /// The action token, or `Unknown` for a rejected or overlong path.
    pub token: Token,
    pub cause: TokenCause,
    /// Confirmation stamp of the token.
    pub stamp_ns: u64,
    pub samples: Vec<EventTrackStep>,
}

/// What one packet did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PacketOutcome {
    /// Tokens confirmed and frames released at this packet.
    pub step: DecodeStep,
    /// Set when the packet was not used at all.
    pub rejected: Option<PacketRejection>,
    /// Human-readable detail of a rejection.
    pub rejection_detail: Option<String>,
    /// Set when this packet interrupted tracking.
    pub interruption: Option<EventInterruptCause>,
    /// The tracker's fault behind that interruption, with its figures (e.g. the confirming
    /// window's majority polarity share).
    pub track_fault: Option<TrackFault>,
    /// Set at the packet whose confirming window turned out one-sided: the track is held in
    /// doubt from here, and dropped as that fault unless it is located again
    /// ([`crate::events::tracker`]).
    pub track_doubt: Option<TrackFault>,
    /// ON and OFF events the tracker saw in its window (after the front end), when it looked.
    pub window_on_off: Option<[u64; 2]>,
    /// Acquisition or lease change at this packet.
    pub acquisition: Option<AcquisitionEvent>,
    /// The estimate fed to the segmenter, if any.
    pub point_px: Option<[f64; 2]>,
    /// The NULL gate offered to the segmenter at this packet.
    pub null_allowed: bool,
}

/// A snapshot of the receiver's state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EventReceiverStatus {
    pub estimate_px: Option<[f64; 2]>,
    pub acquired_ns: Option<u64>,
    pub last_supported_ns: Option<u64>,
    /// Tokens of the incomplete frame held by the parser.
    pub frame_progress: usize,
    /// Packets seen (accepted or not).
    pub packets: u64,
}

/// Most samples kept for the trajectory in progress (60 s at 25 Hz).
const MAX_RECENT_SAMPLES: usize = 1_500;

/// One observer's event receiving chain.
#[derive(Debug, Clone)]
pub struct EventReceiver {
    config: EventReceiverConfig,
    delivery: DeliveryMonitor,
    filter: NoiseFilter,
    /// The packet after the noise front end (reused).
    filtered: EventPacket,
    /// The ego-motion front end and the packet after it (reused).
    ego_motion: EgoMotionFilter,
    moving: EventPacket,
    /// The airframe's turn now, and when the tracker last saw a packet.
    ego: Option<proto::EgoRotation>,
    ego_at_last_packet: Option<proto::EgoRotation>,
    tracker: SupportTracker,
    acquisition: Acquisition,
    decoder: Decoder,
    tokens: Vec<SegmentToken>,
    frames: Vec<ReleasedFrame>,
    trajectories: Vec<EventSymbolTrajectory>,
    recent: Vec<EventTrackStep>,
    interruptions: BTreeMap<EventInterruptCause, u64>,
    acquisition_events: Vec<AcquisitionEvent>,
    /// Segmenter refusals; zero unless the stamp bookkeeping above it is wrong.
    segmenter_errors: u64,
    packets: u64,
    /// Whether tokens, frames, trajectories and acquisition events are kept for the accessors.
    keeps_history: bool,
}

impl EventReceiver {
    pub fn new(config: EventReceiverConfig) -> Result<Self, EventReceiverError> {
        config.validate()?;
        Ok(Self {
            delivery: DeliveryMonitor::new(config.width, config.height, config.packet_period_ns),
            filter: NoiseFilter::new(config.denoise, config.width, config.height)?,
            filtered: EventPacket::from_events(0, (0, 0), (config.width, config.height), &[]),
            ego_motion: EgoMotionFilter::new(
                config.segmenter.home_camera,
                config.width,
                config.height,
            ),
            moving: EventPacket::from_events(0, (0, 0), (config.width, config.height), &[]),
            ego: None,
            ego_at_last_packet: None,
            tracker: SupportTracker::new(config.tracker, config.width, config.height)?,
            acquisition: Acquisition::new(config.acquisition)?,
            decoder: Decoder::new(config.segmenter)?,
            config,
            tokens: Vec::new(),
            frames: Vec::new(),
            trajectories: Vec::new(),
            recent: Vec::new(),
            interruptions: BTreeMap::new(),
            acquisition_events: Vec::new(),
            segmenter_errors: 0,
            packets: 0,
            keeps_history: true,
        })
    }

    /// The same receiver keeping no history: [`Self::tokens`], [`Self::frames`],
    /// [`Self::trajectories`] and [`Self::acquisition_events`] stay empty, while each
    /// [`PacketOutcome`] still carries what it made. A node publishes every outcome as it is
    /// made and never reads the history back, so without it its memory stays flat however long
    /// the session (the history grew by about 150 kB a round).
    #[must_use]
    pub fn without_history(mut self) -> Self {
        self.keeps_history = false;
        self
    }

    pub fn config(&self) -> &EventReceiverConfig {
        &self.config
    }

    /// Every token confirmed so far, in order.
    pub fn tokens(&self) -> &[SegmentToken] {
        &self.tokens
    }

    /// Every frame released so far, in order.
    pub fn frames(&self) -> &[ReleasedFrame] {
        &self.frames
    }

    /// The trajectory of every decoded symbol (action or rejected path), in order.
    pub fn trajectories(&self) -> &[EventSymbolTrajectory] {
        &self.trajectories
    }

    /// Rejected packets per reason.
    pub fn rejections(&self) -> &BTreeMap<PacketRejection, u64> {
        self.delivery.rejections()
    }

    /// Tracking interruptions per cause (rejections included).
    pub fn interruptions(&self) -> &BTreeMap<EventInterruptCause, u64> {
        &self.interruptions
    }

    /// Acquisitions and lease expiries, in order.
    pub fn acquisition_events(&self) -> &[AcquisitionEvent] {
        &self.acquisition_events
    }

    /// Events seen and removed by the noise front end.
    pub fn denoise_counts(&self) -> DenoiseCounts {
        self.filter.counts()
    }

    /// Events seen and removed by the ego-motion front end (zero while no turn was handed over).
    pub fn ego_motion_counts(&self) -> crate::events::ego_motion::EgoMotionCounts {
        self.ego_motion.counts()
    }

    /// Segmenter refusals (stamps out of order); always zero for a correct receiver.
    pub fn segmenter_errors(&self) -> u64 {
        self.segmenter_errors
    }

    /// The window the next packet's local evidence will be gathered in: around the estimate
    /// while tracking, the central search window otherwise.
    pub fn tracking_window(&self) -> Window {
        self.tracker.window()
    }

    pub fn status(&self) -> EventReceiverStatus {
        EventReceiverStatus {
            estimate_px: self.tracker.estimate_px(),
            acquired_ns: self.acquisition.acquired_ns(),
            last_supported_ns: self.acquisition.last_supported_ns(),
            frame_progress: self.decoder.parser().progress(),
            packets: self.packets,
        }
    }

    /// Decodes and consumes one wire message (`proto::encode`d [`EventPacket`]). Bytes that do
    /// not decode are rejected, counted and interrupt tracking.
    pub fn push_bytes(&mut self, bytes: &[u8]) -> PacketOutcome {
        match proto::decode::<EventPacket>(bytes) {
            Ok(packet) => self.push_packet(&packet),
            Err(e) => {
                self.packets += 1;
                let reason = match e {
                    DecodeError::Inconsistent(_) => PacketRejection::Inconsistent,
                    _ => PacketRejection::Undecodable,
                };
                self.delivery.count(reason);
                let mut out = PacketOutcome {
                    rejected: Some(reason),
                    rejection_detail: Some(e.to_string()),
                    ..PacketOutcome::default()
                };
                self.interrupt_at(
                    self.decoder.segmenter().last_stamp_ns(),
                    EventInterruptCause::Rejected(reason),
                    &mut out,
                );
                out
            }
        }
    }

    /// Consumes one packet (the next one of this observer's sensor).
    pub fn push_packet(&mut self, packet: &EventPacket) -> PacketOutcome {
        self.packets += 1;
        let mut out = PacketOutcome::default();
        match self.delivery.check(packet) {
            Delivery::Continuous => {}
            Delivery::Rejected { reason, detail } => {
                out.rejected = Some(reason);
                out.rejection_detail = Some(detail);
                // The packet's own stamps are not trusted: interrupt at the last good stamp.
                self.interrupt_at(
                    self.decoder.segmenter().last_stamp_ns(),
                    EventInterruptCause::Rejected(reason),
                    &mut out,
                );
                return out;
            }
            Delivery::Discontinuous {
                cause,
                events_usable,
            } => {
                if !events_usable {
                    self.interrupt_at(Some(packet.end_ns), cause.into(), &mut out);
                    return out;
                }
                // The missing interval ends where this packet starts; its own events can
                // localise the target afresh.
                self.interrupt_at(Some(packet.start_ns), cause.into(), &mut out);
            }
        }
        let stamp_ns = packet.end_ns;
        let escalated = self.filter.escalated();
        self.filter.filter(packet, &mut self.filtered);
        if self.filter.escalated() && !escalated {
            // The filter has just measured that what it let through was mostly noise: a track
            // it confirmed on that output must be confirmed again on what it lets through now.
            self.tracker.doubt();
        }
        let seen = if self.ego_motion.active() {
            // What the front end keeps is whole cells: the support's median, not its
            // percentile bounds, tells where the target is in them (`support::Centre`).
            self.tracker.set_centre(Centre::Median);
            self.turn_estimate();
            self.ego_motion.filter(&self.filtered, &mut self.moving);
            &self.moving
        } else {
            &self.filtered
        };
        self.ego_at_last_packet = self.ego;
        let doubted = self.tracker.polarity_doubted();
        let observation = self.tracker.observe(seen);
        if !doubted {
            out.track_doubt = self.tracker.doubted_by();
        }
        if let Observation::Located { evidence, .. }
        | Observation::Held { evidence, .. }
        | Observation::NoTarget { evidence } = &observation
        {
            out.window_on_off = Some([evidence.on_events as u64, evidence.off_events() as u64]);
        }
        match observation {
            Observation::Interrupted(fault) => {
                out.track_fault = Some(fault);
                self.interrupt_at(Some(stamp_ns), fault.into(), &mut out)
            }
            Observation::Located { point_px, .. } => self.track(stamp_ns, point_px, true, &mut out),
            Observation::Held { point_px, .. } => self.track(stamp_ns, point_px, false, &mut out),
            Observation::NoTarget { .. } => {
                if self.fed() {
                    self.feed(Sample::lost(stamp_ns), &mut out);
                }
            }
        }
        out
    }

    /// Reports missing input the packets cannot show (a publisher gone, a fault) at `stamp_ns`
    /// (clamped to the last stamp the receiver has used).
    pub fn interrupt(&mut self, stamp_ns: u64) -> PacketOutcome {
        let mut out = PacketOutcome::default();
        let stamp_ns = stamp_ns.max(self.decoder.segmenter().last_stamp_ns().unwrap_or(0));
        self.interrupt_at(Some(stamp_ns), EventInterruptCause::External, &mut out);
        out
    }

    /// How far the observer's airframe has turned from its home attitude (its attitude
    /// estimate), undone on the target's track from the next sample on
    /// ([`proto::stabilise`]).
    pub fn set_ego_rotation(&mut self, ego: Option<proto::EgoRotation>) {
        self.ego = ego;
        self.ego_motion.set_ego_rotation(ego);
        self.decoder.set_ego_rotation(ego);
    }

    /// Moves the tracker's estimate by the image motion the airframe's turn since the last
    /// packet explains, as the RGB receiver starts each feature's search (an inertial-aided
    /// prediction): a target that makes no events (hovering, or its cell learnt by the
    /// ego-motion front end) is held where the turn put it, not where the image was.
    fn turn_estimate(&mut self) {
        let (from, to) = (self.ego_at_last_packet, self.ego);
        if from == to {
            return;
        }
        if let Some(home) = &self.config.segmenter.home_camera {
            self.tracker
                .turn_estimate(|p| predicted_px(home, from.as_ref(), to.as_ref(), p));
        }
    }

    /// The check the session's frames carry ([`Decoder::set_frame_check`]).
    pub fn set_frame_check(&mut self, check: proto::FrameCheck) {
        self.decoder.set_frame_check(check);
    }

    /// Starts afresh (a round reset or a new reception window): target, acquisition, segmenter
    /// and incomplete frame are forgotten without a token, and the next packet starts a new
    /// stream. History and counters are kept.
    pub fn reset(&mut self) {
        self.decoder.reset();
        self.tracker.lose();
        self.acquisition.revoke();
        self.delivery.forget();
        self.recent.clear();
    }

    fn fed(&self) -> bool {
        self.decoder.segmenter().last_stamp_ns().is_some()
    }

    fn track(
        &mut self,
        stamp_ns: u64,
        point_px: [f64; 2],
        supported: bool,
        out: &mut PacketOutcome,
    ) {
        // Closure and rest are judged where the segmenter judges symbols: in the image the
        // unturned camera would have made. In the raw image a leaning observer's sweep does not
        // come back to where it started, and its rests wander by the lean.
        let steady_px = match (&self.ego, &self.config.segmenter.home_camera) {
            (Some(ego), Some(home)) => stabilised_px(home, ego, point_px).unwrap_or(point_px),
            _ => point_px,
        };
        if let Some(event) = self.acquisition.observe(stamp_ns, steady_px, supported) {
            if self.keeps_history {
                self.acquisition_events.push(event);
            }
            out.acquisition = Some(event);
        }
        let null_allowed = self.acquisition.null_allowed(stamp_ns);
        out.point_px = Some(point_px);
        out.null_allowed = null_allowed;
        if self.recent.len() >= MAX_RECENT_SAMPLES {
            self.recent.drain(..MAX_RECENT_SAMPLES / 2);
        }
        self.recent.push(EventTrackStep {
            stamp_ns,
            point_px,
            supported,
        });
        self.feed(
            Sample {
                stamp_ns,
                point_px: Some(point_px),
                reliable: true,
                null_allowed,
            },
            out,
        );
    }

    fn interrupt_at(
        &mut self,
        stamp_ns: Option<u64>,
        cause: EventInterruptCause,
        out: &mut PacketOutcome,
    ) {
        self.tracker.lose();
        self.acquisition.revoke();
        self.recent.clear();
        *self.interruptions.entry(cause).or_insert(0) += 1;
        out.interruption = Some(cause);
        if let Some(stamp_ns) = stamp_ns
            && self.fed()
        {
            match self.decoder.interrupt(stamp_ns) {
                Ok(step) => self.absorb(step, out),
                Err(_) => self.segmenter_errors += 1,
            }
        }
    }

    fn feed(&mut self, sample: Sample, out: &mut PacketOutcome) {
        match self.decoder.push(sample) {
            Ok(step) => self.absorb(step, out),
            Err(_) => self.segmenter_errors += 1,
        }
    }

    fn absorb(&mut self, step: DecodeStep, out: &mut PacketOutcome) {
        for token in &step.tokens {
            match (token.token, token.cause) {
                // A late NULL (stamped in the past) keeps the samples after it.
                (Token::Null, _) => self.recent.retain(|s| s.stamp_ns > token.stamp_ns),
                (_, TokenCause::Interrupted(_)) => {}
                _ if !self.keeps_history => {}
                _ => self.trajectories.push(EventSymbolTrajectory {
                    token: token.token,
                    cause: token.cause,
                    stamp_ns: token.stamp_ns,
                    // A late reading's samples went with the NULL after it: none are kept.
                    samples: if token.late {
                        Vec::new()
                    } else {
                        self.recent.clone()
                    },
                }),
            }
        }
        if self.keeps_history {
            self.tokens.extend_from_slice(&step.tokens);
            self.frames.extend(step.frames.iter().cloned());
        }
        out.step.tokens.extend(step.tokens);
        out.step.frames.extend(step.frames);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::Polarity;

    const P: u64 = 40_000_000;

    fn packet(seq: u64, events: &[(u16, u16, Polarity)]) -> EventPacket {
        let events: Vec<_> = events.iter().map(|&(x, y, p)| (x, y, 1, p)).collect();
        EventPacket::from_events(seq, (seq * P, (seq + 1) * P), (640, 480), &events)
    }

    /// Both outlines of a dark 48x12 bar moving right, centred at (cx, 240).
    fn bar(cx: u16) -> Vec<(u16, u16, Polarity)> {
        let mut ev = Vec::new();
        for dy in 0..12 {
            for dx in 0..3 {
                ev.push((cx + 22 + dx, 234 + dy, Polarity::Off));
                ev.push((cx - 25 + dx, 234 + dy, Polarity::On));
            }
        }
        ev
    }

    fn receiver() -> EventReceiver {
        EventReceiver::new(EventReceiverConfig::paper()).unwrap()
    }

    #[test]
    fn nothing_reaches_the_decoder_before_a_target_was_localised() {
        let mut rx = receiver();
        for seq in 0..10 {
            // The tracker looked, in its search window, and saw nothing.
            let nothing = PacketOutcome {
                window_on_off: Some([0, 0]),
                ..PacketOutcome::default()
            };
            assert_eq!(rx.push_packet(&packet(seq, &[])), nothing);
        }
        // Faults before any target: counted, but no token to report.
        let out = rx.push_bytes(b"not a packet");
        assert_eq!(out.rejected, Some(PacketRejection::Undecodable));
        assert_eq!(
            out.interruption,
            Some(EventInterruptCause::Rejected(PacketRejection::Undecodable))
        );
        assert!(
            rx.push_packet(&packet(12, &[])).interruption == Some(EventInterruptCause::SequenceGap)
        );
        rx.interrupt(0);
        assert!(rx.tokens().is_empty());
        assert_eq!(rx.rejections().get(&PacketRejection::Undecodable), Some(&1));
        assert_eq!(
            rx.interruptions().get(&EventInterruptCause::External),
            Some(&1)
        );
        assert_eq!(rx.status().packets, 12);
    }

    #[test]
    fn a_fault_while_tracking_reports_one_unknown_and_drops_the_target() {
        let mut rx = receiver();
        let out = rx.push_packet(&packet(0, &bar(320)));
        assert!(
            out.point_px.is_some() && !out.null_allowed,
            "tracked, not acquired"
        );
        let mut bad = packet(1, &bar(322));
        bad.continuous = false;
        let out = rx.push_packet(&bad);
        assert_eq!(out.interruption, Some(EventInterruptCause::NotContinuous));
        assert_eq!(out.step.tokens.len(), 1);
        assert_eq!(out.step.tokens[0].token, Token::Unknown);
        assert_eq!(out.step.tokens[0].stamp_ns, 2 * P);
        assert_eq!(rx.status().estimate_px, None);
        // Further lost steps add nothing: one Unknown per interruption episode.
        assert!(rx.push_packet(&packet(2, &[])).step.tokens.is_empty());
    }

    #[test]
    fn reset_starts_a_new_stream_without_tokens() {
        let mut rx = receiver();
        rx.push_packet(&packet(40, &bar(320)));
        rx.reset();
        // An earlier sequence number and time are a new stream after a reset, not a fault.
        let out = rx.push_packet(&packet(3, &bar(320)));
        assert_eq!((out.rejected, out.interruption), (None, None));
        assert!(out.point_px.is_some());
        assert!(rx.tokens().is_empty());
        assert_eq!(rx.segmenter_errors(), 0);
    }

    #[test]
    fn unusable_settings_are_rejected() {
        let mut c = EventReceiverConfig::paper();
        c.packet_period_ns = 100_000_000;
        assert!(matches!(
            EventReceiver::new(c),
            Err(EventReceiverError::BadSetting { .. })
        ));
        let mut c = EventReceiverConfig::paper();
        c.acquisition.lease_ns = 0;
        assert!(EventReceiver::new(c).is_err());
        let mut c = EventReceiverConfig::paper();
        c.segmenter.anchor_radius_px = f64::NAN;
        assert!(matches!(
            EventReceiver::new(c),
            Err(EventReceiverError::Segmenter(_))
        ));
    }
}
