//! Event-support tracking: localise the target's event support near the optical centre, then
//! follow it inside a local window, one 40 ms packet at a time.
//!
//! Each packet is judged in a fixed order (paper, "Event-only trajectories"):
//! 1. **Broad activity** — many coarse cells of the whole sensor active (the observer moving, a
//!    lighting change): the packet says nothing about the target; tracking is interrupted.
//! 2. **Support** — at least [`EventTrackerConfig::min_unique_pixels`] distinct pixels spanning at
//!    least [`EventTrackerConfig::min_axis_span_px`] on both axes (and not collinear). Without it the
//!    packet is *insufficient evidence*: the estimate holds. A sparse deceleration tail lands
//!    here, whatever its polarity.
//! 3. **Polarity balance** — judged only on supported evidence: a strongly one-sided set (a flash,
//!    a target vanishing from its place) interrupts tracking.
//! 4. Otherwise the support centre (midpoint of the 2.5th / 97.5th percentile bounds) updates
//!    the estimate through exponential smoothing.
//!
//! The order of 2 and 3 is the fix for the paper's 285.12 s failure, where a polarity check run
//! first read 19 OFF events at 12 collinear pixels as a disappearance ([`support_first`]).
//!
//! **Polarity is confirmed over a short time window.** A moving target also produces supported
//! one-sided packets: log contrast makes the dark side of an edge cross the threshold first, so
//! a straight-edged target starting to move diagonally fires its whole trailing outline (an L,
//! two-dimensional) as ON a packet before its leading outline fires OFF, and turnarounds do the
//! same in reverse. A flash or a disappearance stays one-sided. So a supported one-sided packet
//! only suspends the estimate (it holds); the balance of the local events of the
//! [`EventTrackerConfig::polarity_context_packets`] packets before it, itself and the packet after it
//! decides: balanced → tracking goes on.
//!
//! **A one-sided window is a doubt, not a verdict.** A target that stops fires its trailing
//! edge alone too (the last packets of a stroke under shot noise can be > 90 % one polarity),
//! and a stopped target is silent until it moves again. What tells a stop from a disappearance is
//! what follows: a target that stopped is located again near where it was held, one that left is
//! not. So a confirmed one-sided window holds the track and takes back its confirmation: it must
//! be located twice again within [`EventTrackerConfig::unconfirmed_hold_packets`], as a new track
//! must (M-of-N confirmation), or it is dropped then as a one-sided interruption with the
//! window's figures — unless it was answered in place.
//!
//! **A doubt is answered in place.** A target that stops and settles (a flown drone overshoots
//! by a fraction of a pixel and creeps back) fires the opposite polarity where it was held; one
//! that left fires nothing there. So from the first doubt on, the local events of the doubting
//! window and of every packet after it are counted, across later doubts: when a hold runs out
//! and the polarity opposite to the window's has fired at least a tenth as many events as the
//! window had, the track is confirmed again and held, not dropped. A settle can outlast a hold
//! and be split by locations in place, so the count is kept until the target is located twice
//! more than [`EventTrackerConfig::settle_px`] from where it was held (it moved on). A settling
//! edge is a line of a few pixels firing again and again, never support, so unsupported packets
//! count too; at rest the noise filter passes almost nothing into the local window (a median of
//! 0 events a packet under 10 Hz of shot noise), far below a tenth of a target's change.

use std::collections::VecDeque;

use proto::EventPacket;

use crate::events::error::EventReceiverError;
use crate::events::support::{
    Centre, Evidence, SupportScratch, Window, active_cells, gather_centred,
};

/// Tracker settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EventTrackerConfig {
    /// Fewest distinct event pixels that can localise the target (paper: 24).
    pub min_unique_pixels: usize,
    /// Smallest `max − min` of those pixels on each axis (paper: 2 px).
    pub min_axis_span_px: u16,
    /// Smallest spread across the support's principal axis: catches diagonal lines that pass
    /// the axis-span test but are still one-dimensional.
    pub min_minor_spread_px: f64,
    /// Supported evidence whose more frequent polarity has at least this share is one-sided.
    pub one_sided_fraction: f64,
    /// Preceding packets whose local events join a one-sided packet (and the one after it) in
    /// the confirming polarity balance.
    pub polarity_context_packets: usize,
    /// Half-sizes of the acquisition search window around the optical centre.
    pub search_half_px: [f64; 2],
    /// Half-sizes of the local tracking window around the current estimate.
    pub track_half_px: [f64; 2],
    /// Weight of a new support centre in the exponential smoothing (1 = no smoothing).
    pub smoothing: f64,
    /// Cell size of the broad-activity grid.
    pub broad_cell_px: u16,
    /// Events a cell needs to count as active.
    pub broad_cell_min_events: u32,
    /// This many active cells anywhere on the sensor is broad scene activity.
    pub broad_active_cells: usize,
    /// A track located by one packet only is a blip, not a target, once this many packets
    /// after it have not located it again: it is dropped, not held (0: every track is held,
    /// even one a one-sided window doubted).
    pub unconfirmed_hold_packets: u32,
    /// A doubted target located again within this distance of where it was held is still
    /// settling in place, not moving on: half the drone's image height at 1.3 m. It settles
    /// within a pixel, but the support of its sparse settling packets puts the estimate up to
    /// a few pixels off; a stroke moves it up to 8 px a packet.
    pub settle_px: f64,
}

impl EventTrackerConfig {
    /// The paper's support rule with this implementation's windows and thresholds: the search
    /// window covers the central half of a 640×480 view (symbols span ≤ ±105 px around the
    /// performer's hover point), the local window ±64×±48 px (the drone is ≈ 48×12 px and moves
    /// ≤ 8 px per packet), and broad activity is ≥ 40 of the 300 cells of 32 px (a moving drone
    /// lights ≤ 8).
    pub fn paper() -> Self {
        Self {
            min_unique_pixels: 24,
            min_axis_span_px: 2,
            min_minor_spread_px: 0.5,
            one_sided_fraction: 0.9,
            polarity_context_packets: 2,
            search_half_px: [160.0, 120.0],
            track_half_px: [64.0, 48.0],
            smoothing: 0.6,
            broad_cell_px: 32,
            broad_cell_min_events: 4,
            broad_active_cells: 40,
            unconfirmed_hold_packets: 12,
            settle_px: 6.0,
        }
    }

    /// Rejects settings no tracker could run with.
    pub fn validate(&self) -> Result<(), EventReceiverError> {
        let bad = |setting: &'static str, reason: String| {
            Err(EventReceiverError::BadSetting { setting, reason })
        };
        let positive = |v: [f64; 2]| v.iter().all(|h| h.is_finite() && *h > 0.0);
        if self.min_unique_pixels == 0 {
            return bad("min_unique_pixels", "must be positive".into());
        }
        if !(self.min_minor_spread_px.is_finite() && self.min_minor_spread_px >= 0.0) {
            return bad(
                "min_minor_spread_px",
                format!("{} is not a distance", self.min_minor_spread_px),
            );
        }
        if !(self.one_sided_fraction > 0.5 && self.one_sided_fraction <= 1.0) {
            return bad(
                "one_sided_fraction",
                format!("{} is outside (0.5, 1]", self.one_sided_fraction),
            );
        }
        if !(self.settle_px.is_finite() && self.settle_px >= 0.0) {
            return bad("settle_px", format!("{} is not a distance", self.settle_px));
        }
        if !positive(self.search_half_px) {
            return bad(
                "search_half_px",
                format!("{:?} is not finite and positive", self.search_half_px),
            );
        }
        if !positive(self.track_half_px) {
            return bad(
                "track_half_px",
                format!("{:?} is not finite and positive", self.track_half_px),
            );
        }
        if !(self.smoothing > 0.0 && self.smoothing <= 1.0) {
            return bad("smoothing", format!("{} is outside (0, 1]", self.smoothing));
        }
        if self.broad_cell_px == 0 || self.broad_active_cells == 0 {
            return bad(
                "broad_cell_px / broad_active_cells",
                "must be positive".into(),
            );
        }
        Ok(())
    }
}

impl Default for EventTrackerConfig {
    fn default() -> Self {
        Self::paper()
    }
}

/// What the local evidence of one packet says.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Judgement {
    /// Enough two-dimensional, balanced support: the target's centre is here.
    Locate([f64; 2]),
    /// Too little or degenerate support: no statement about the target.
    Insufficient,
    /// Supported but one-sided polarity: the scene changed, not the target's position.
    OneSided,
}

/// True when `evidence` is enough to localise a two-dimensional target.
pub fn is_supported(evidence: &Evidence, config: &EventTrackerConfig) -> bool {
    evidence.unique_pixels >= config.min_unique_pixels
        && evidence.span_px[0] >= config.min_axis_span_px
        && evidence.span_px[1] >= config.min_axis_span_px
        && evidence.minor_spread_px >= config.min_minor_spread_px
}

/// The receiver's rule for one packet: support first, polarity balance only on supported
/// evidence. (A `OneSided` packet is then confirmed over time, see the module docs.)
pub fn support_first(evidence: &Evidence, config: &EventTrackerConfig) -> Judgement {
    if !is_supported(evidence, config) {
        return Judgement::Insufficient;
    }
    if evidence.majority_fraction() >= config.one_sided_fraction {
        return Judgement::OneSided;
    }
    match evidence.centre_px {
        Some(c) => Judgement::Locate(c),
        None => Judgement::Insufficient,
    }
}

/// Why the tracker gave up its target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TrackFault {
    /// This many coarse cells of the sensor were active.
    BroadActivity { active_cells: usize },
    /// The track was located by one packet and by none of the next `held_packets`: a blip
    /// (track confirmation, as in M-of-N track initiation: Blackman & Popoli 1999, §3.2).
    Unconfirmed { held_packets: u32 },
    /// Supported one-sided local evidence, confirmed by the events around it: the share of the
    /// majority polarity and the number of events in the confirming window.
    OneSidedPolarity { majority_fraction: f64, events: u64 },
}

/// The tracker's reading of one packet.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Observation {
    /// Event-supported estimate (smoothed) and the raw support centre it came from.
    Located {
        point_px: [f64; 2],
        centre_px: [f64; 2],
        evidence: Evidence,
    },
    /// Insufficient (or one-sided, awaiting confirmation) evidence while tracking: the
    /// estimate holds where it was.
    Held {
        point_px: [f64; 2],
        evidence: Evidence,
    },
    /// Searching, and nothing localisable near the optical centre.
    NoTarget { evidence: Evidence },
    /// Tracking was interrupted; the tracker is searching again.
    Interrupted(TrackFault),
}

impl Observation {
    /// The estimate this observation leaves the tracker with, if any.
    pub fn point_px(&self) -> Option<[f64; 2]> {
        match self {
            Observation::Located { point_px, .. } | Observation::Held { point_px, .. } => {
                Some(*point_px)
            }
            Observation::NoTarget { .. } | Observation::Interrupted(_) => None,
        }
    }
}

/// Local ON / OFF event counts.
type Counts = [u64; 2];

/// The local events since a track was first put in doubt: kept across later doubts and
/// relocations in place, until the target is located twice more than
/// [`EventTrackerConfig::settle_px`] from where it was held.
#[derive(Debug, Clone, Copy)]
struct Presence {
    /// The estimate when the first doubt came.
    at_px: [f64; 2],
    /// Counts of the doubting window.
    window: Counts,
    /// Counts of every packet after it.
    after: Counts,
}

/// Event-support tracker for one sensor.
#[derive(Debug, Clone)]
pub struct SupportTracker {
    config: EventTrackerConfig,
    width: u16,
    height: u16,
    /// Current smoothed estimate; `None` while searching.
    estimate_px: Option<[f64; 2]>,
    /// Local counts of the last `polarity_context_packets` packets.
    context: VecDeque<Counts>,
    /// A supported one-sided packet awaiting confirmation: counts of its context and itself.
    pending: Option<Counts>,
    /// The confirmed one-sided window that doubted the current track, reported if the track is
    /// dropped before it is confirmed again.
    doubted_by: Option<TrackFault>,
    /// What has fired where the track was first doubted since it last moved on.
    presence: Option<Presence>,
    /// Packets that located the current track (saturating) and packets since the last one.
    located_packets: u32,
    held_packets: u32,
    /// Where a support's centre is put (the paper's rule until a turning camera asks for
    /// the median).
    centre: Centre,
    scratch: SupportScratch,
}

impl SupportTracker {
    /// A tracker for a `width`×`height` sensor.
    pub fn new(
        config: EventTrackerConfig,
        width: u16,
        height: u16,
    ) -> Result<Self, EventReceiverError> {
        config.validate()?;
        if width == 0 || height == 0 {
            return Err(EventReceiverError::BadSetting {
                setting: "width / height",
                reason: format!("sensor {width}x{height} has no pixels"),
            });
        }
        Ok(Self {
            config,
            width,
            height,
            estimate_px: None,
            context: VecDeque::with_capacity(config.polarity_context_packets + 1),
            pending: None,
            doubted_by: None,
            presence: None,
            located_packets: 0,
            held_packets: 0,
            centre: Centre::PercentileMidpoint,
            scratch: SupportScratch::new(width, height),
        })
    }

    pub fn config(&self) -> &EventTrackerConfig {
        &self.config
    }

    /// Current estimate, `None` while searching.
    pub fn estimate_px(&self) -> Option<[f64; 2]> {
        self.estimate_px
    }

    /// The camera turned since the last packet: the estimate moves to where `turn` takes it
    /// (the image of a point the turn alone moved), so that a held track stays on the target
    /// while the airframe swings, and a located one is smoothed from there. Kept where `turn`
    /// cannot map it.
    pub fn turn_estimate(&mut self, turn: impl FnOnce([f64; 2]) -> Option<[f64; 2]>) {
        if let Some(moved) = self.estimate_px.and_then(turn) {
            self.estimate_px = Some(moved);
        }
    }

    /// True while a one-sided packet awaits confirmation by the next one.
    pub fn polarity_pending(&self) -> bool {
        self.pending.is_some()
    }

    /// The window the next packet will be judged in.
    pub fn window(&self) -> Window {
        match self.estimate_px {
            Some(p) => Window::centred(p, self.config.track_half_px, self.width, self.height),
            None => Window::centred(
                [f64::from(self.width) / 2.0, f64::from(self.height) / 2.0],
                self.config.search_half_px,
                self.width,
                self.height,
            ),
        }
    }

    /// Puts the centre of every later packet's support by `rule`.
    pub fn set_centre(&mut self, rule: Centre) {
        self.centre = rule;
    }

    /// Drops the target (a delivery discontinuity or a reset): search again.
    pub fn lose(&mut self) {
        self.estimate_px = None;
        self.context.clear();
        self.pending = None;
        self.doubted_by = None;
        self.presence = None;
        self.located_packets = 0;
        self.held_packets = 0;
    }

    /// True while a confirmed one-sided window has doubted the track and it has not been
    /// confirmed again.
    pub fn polarity_doubted(&self) -> bool {
        self.doubted_by.is_some()
    }

    /// The confirmed one-sided window that doubted the track, while the doubt lasts.
    pub fn doubted_by(&self) -> Option<TrackFault> {
        self.doubted_by
    }

    /// Takes back the track's confirmation (it is kept, but it is dropped as a blip unless
    /// located twice again before [`EventTrackerConfig::unconfirmed_hold_packets`] pass).
    pub fn doubt(&mut self) {
        self.located_packets = 0;
        self.held_packets = 0;
    }

    /// Counts one more packet without location; true when that makes the track a blip.
    fn unconfirmed(&mut self) -> bool {
        self.held_packets = self.held_packets.saturating_add(1);
        let limit = self.config.unconfirmed_hold_packets;
        limit > 0 && self.located_packets < 2 && self.held_packets >= limit
    }

    /// True when the polarity opposite to the first doubt's window has fired locally since,
    /// at least the minority share a balanced window may have of that window's events.
    fn answered(&self) -> bool {
        self.presence.is_some_and(|Presence { window, after, .. }| {
            let opposite = if window[0] >= window[1] {
                after[1]
            } else {
                after[0]
            };
            let events = (window[0] + window[1]) as f64;
            opposite > 0 && opposite as f64 >= (1.0 - self.config.one_sided_fraction) * events
        })
    }

    /// Reads one consistent packet of this sensor's size.
    pub fn observe(&mut self, packet: &EventPacket) -> Observation {
        if !packet.is_empty() {
            let cells = active_cells(
                packet,
                self.config.broad_cell_px,
                self.config.broad_cell_min_events,
                &mut self.scratch,
            );
            if cells >= self.config.broad_active_cells {
                self.lose();
                return Observation::Interrupted(TrackFault::BroadActivity {
                    active_cells: cells,
                });
            }
        }
        let evidence = gather_centred(packet, self.window(), self.centre, &mut self.scratch);
        let counts = [evidence.on_events as u64, evidence.off_events() as u64];
        // This packet joins the presence count unless a window that already holds it starts it.
        let mut counted = false;
        if let Some(pending) = self.pending.take() {
            let window = [pending[0] + counts[0], pending[1] + counts[1]];
            let events = window[0] + window[1];
            let majority_fraction = window[0].max(window[1]) as f64 / events as f64;
            if majority_fraction >= self.config.one_sided_fraction && self.estimate_px.is_some() {
                // A second window while still in doubt restarts the count of locations, not
                // the hold: a scene that stays one-sided cannot keep a track alive.
                self.located_packets = 0;
                if self.doubted_by.is_none() {
                    self.held_packets = 0;
                    self.doubted_by = Some(TrackFault::OneSidedPolarity {
                        majority_fraction,
                        events,
                    });
                }
                if let (None, Some(at_px)) = (self.presence, self.estimate_px) {
                    self.presence = Some(Presence {
                        at_px,
                        window,
                        after: [0, 0],
                    });
                    counted = true;
                }
            }
        }
        // Every local event counts, supported or not: a settling edge is a line of a few
        // pixels firing again and again, never support. What the noise filter lets through at
        // rest is too little to answer a change of a target's size (module docs).
        if let Some(presence) = self.presence.as_mut()
            && !counted
        {
            presence.after[0] += counts[0];
            presence.after[1] += counts[1];
        }
        let observation = match support_first(&evidence, &self.config) {
            Judgement::Locate(centre_px) => {
                let a = self.config.smoothing;
                let point_px = match self.estimate_px {
                    Some(p) => [
                        p[0] + a * (centre_px[0] - p[0]),
                        p[1] + a * (centre_px[1] - p[1]),
                    ],
                    None => centre_px,
                };
                self.estimate_px = Some(point_px);
                self.located_packets = self.located_packets.saturating_add(1);
                self.held_packets = 0;
                if self.located_packets >= 2 {
                    self.doubted_by = None;
                    // Located twice where it was held is a target still settling, whose other
                    // half of the settle may follow; located away from it, it has moved on.
                    let settle_px = self.config.settle_px;
                    if self.presence.is_some_and(|p| {
                        (point_px[0] - p.at_px[0]).hypot(point_px[1] - p.at_px[1]) > settle_px
                    }) {
                        self.presence = None;
                    }
                }
                Observation::Located {
                    point_px,
                    centre_px,
                    evidence,
                }
            }
            judgement => {
                if judgement == Judgement::OneSided {
                    let mut window = counts;
                    for c in &self.context {
                        window[0] += c[0];
                        window[1] += c[1];
                    }
                    self.pending = Some(window);
                }
                let mut blip = self.estimate_px.is_some() && self.unconfirmed();
                if blip && self.doubted_by.is_some() && self.answered() {
                    // The one-sided change was answered in place by the opposite polarity: a
                    // target that stopped and settles, not one that left. Confirmed again.
                    blip = false;
                    self.doubted_by = None;
                    self.located_packets = 2;
                    self.held_packets = 0;
                }
                match self.estimate_px {
                    Some(_) if blip => {
                        let fault = self.doubted_by.unwrap_or(TrackFault::Unconfirmed {
                            held_packets: self.held_packets,
                        });
                        self.lose();
                        return Observation::Interrupted(fault);
                    }
                    Some(point_px) => Observation::Held { point_px, evidence },
                    None => Observation::NoTarget { evidence },
                }
            }
        };
        if self.config.polarity_context_packets > 0 {
            if self.context.len() == self.config.polarity_context_packets {
                self.context.pop_front();
            }
            self.context.push_back(counts);
        }
        observation
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::Polarity;

    fn packet(events: &[(u16, u16, Polarity)]) -> EventPacket {
        let events: Vec<_> = events.iter().map(|&(x, y, p)| (x, y, 1, p)).collect();
        EventPacket::from_events(0, (0, 40_000_000), (640, 480), &events)
    }

    /// A moving dark bar's edges: OFF at the leading column block, ON at the trailing one.
    fn moving_bar(cx: u16, cy: u16) -> Vec<(u16, u16, Polarity)> {
        let mut ev = Vec::new();
        for dy in 0..12 {
            for dx in 0..3 {
                ev.push((cx + 22 + dx, cy - 6 + dy, Polarity::Off));
                ev.push((cx - 25 + dx, cy - 6 + dy, Polarity::On));
            }
        }
        ev
    }

    fn tracker() -> SupportTracker {
        SupportTracker::new(EventTrackerConfig::paper(), 640, 480).unwrap()
    }

    #[test]
    fn localises_near_the_optical_centre_then_smooths_within_a_local_window() {
        let mut t = tracker();
        let first = t.observe(&packet(&moving_bar(330, 240)));
        let Observation::Located { point_px, .. } = first else {
            panic!("{first:?}")
        };
        assert!((point_px[0] - 330.0).abs() < 1.0 && (point_px[1] - 240.0).abs() < 1.0);
        // The next centre 10 px right: the estimate moves by the smoothing weight.
        let next = t.observe(&packet(&moving_bar(340, 240)));
        let p = next.point_px().unwrap();
        assert!((p[0] - (point_px[0] + 0.6 * 10.0)).abs() < 1e-9, "{p:?}");
    }

    #[test]
    fn a_track_located_once_is_dropped_after_its_hold_but_a_confirmed_one_is_held() {
        let limit = EventTrackerConfig::paper().unconfirmed_hold_packets;
        let mut blip = tracker();
        blip.observe(&packet(&moving_bar(330, 240)));
        for _ in 1..limit {
            assert!(matches!(
                blip.observe(&packet(&[])),
                Observation::Held { .. }
            ));
        }
        assert_eq!(
            blip.observe(&packet(&[])),
            Observation::Interrupted(TrackFault::Unconfirmed {
                held_packets: limit
            })
        );
        assert_eq!(blip.estimate_px(), None, "searching again");
        // Located twice: a target, held through any quiet.
        let mut target = tracker();
        target.observe(&packet(&moving_bar(330, 240)));
        target.observe(&packet(&moving_bar(334, 240)));
        for _ in 0..10 * limit {
            assert!(matches!(
                target.observe(&packet(&[])),
                Observation::Held { .. }
            ));
        }
    }

    #[test]
    fn a_doubted_track_must_be_located_again_or_is_dropped() {
        let limit = EventTrackerConfig::paper().unconfirmed_hold_packets;
        let confirmed = |t: &mut SupportTracker| {
            t.observe(&packet(&moving_bar(330, 240)));
            t.observe(&packet(&moving_bar(334, 240)));
            for _ in 0..3 * limit {
                t.observe(&packet(&[]));
            }
        };
        // Doubted while quiet: held for the hold, then dropped.
        let mut t = tracker();
        confirmed(&mut t);
        t.doubt();
        for _ in 1..limit {
            assert!(matches!(t.observe(&packet(&[])), Observation::Held { .. }));
        }
        assert!(matches!(
            t.observe(&packet(&[])),
            Observation::Interrupted(TrackFault::Unconfirmed { .. })
        ));
        assert_eq!(t.estimate_px(), None);
        // Doubted, then located twice again: confirmed, held through any quiet.
        let mut t = tracker();
        confirmed(&mut t);
        t.doubt();
        t.observe(&packet(&moving_bar(338, 240)));
        t.observe(&packet(&moving_bar(342, 240)));
        for _ in 0..3 * limit {
            assert!(matches!(t.observe(&packet(&[])), Observation::Held { .. }));
        }
    }

    #[test]
    fn support_outside_the_search_window_does_not_acquire() {
        let mut t = tracker();
        let obs = t.observe(&packet(&moving_bar(580, 60)));
        assert!(matches!(obs, Observation::NoTarget { .. }), "{obs:?}");
        assert_eq!(t.estimate_px(), None);
    }

    #[test]
    fn sparse_or_collinear_one_sided_evidence_holds_the_estimate() {
        let mut t = tracker();
        t.observe(&packet(&moving_bar(320, 240)));
        let held_at = t.estimate_px().unwrap();
        // Quiet first, so no balanced motion around it can dilute the tail's polarity.
        for _ in 0..3 {
            assert!(matches!(t.observe(&packet(&[])), Observation::Held { .. }));
        }
        // The paper's packet: 19 OFF events at 12 collinear pixels.
        let line: Vec<_> = (0..19)
            .map(|i| (340 + (i % 12) as u16, 246, Polarity::Off))
            .collect();
        let obs = t.observe(&packet(&line));
        assert_eq!(
            obs,
            Observation::Held {
                point_px: held_at,
                evidence: obs_evidence(&obs)
            }
        );
        assert!(
            !t.polarity_pending(),
            "insufficient support is never polarity evidence"
        );
        // 40 OFF events on a diagonal: enough pixels and axis span, but one-dimensional.
        let diagonal: Vec<_> = (0..40)
            .map(|i| (300 + i, 220 + i / 2, Polarity::Off))
            .collect();
        assert!(matches!(
            t.observe(&packet(&diagonal)),
            Observation::Held { .. }
        ));
        // Quiet after them: still held, never interrupted.
        for _ in 0..3 {
            assert!(matches!(t.observe(&packet(&[])), Observation::Held { .. }));
        }
        assert_eq!(t.estimate_px(), Some(held_at));
    }

    fn obs_evidence(obs: &Observation) -> Evidence {
        match obs {
            Observation::Located { evidence, .. }
            | Observation::Held { evidence, .. }
            | Observation::NoTarget { evidence } => *evidence,
            Observation::Interrupted(_) => Evidence::EMPTY,
        }
    }

    /// The whole 48x12 footprint of a target at (cx, cy) changing one way (vanishing: ON).
    fn footprint(cx: u16, cy: u16, polarity: Polarity) -> Vec<(u16, u16, Polarity)> {
        (0..48 * 12)
            .map(|i| {
                (
                    cx - 24 + (i % 48) as u16,
                    cy - 6 + (i / 48) as u16,
                    polarity,
                )
            })
            .collect()
    }

    /// A target located twice (confirmed), then its whole footprint changing one way.
    fn confirmed_then_one_sided(t: &mut SupportTracker) -> [f64; 2] {
        t.observe(&packet(&moving_bar(316, 240)));
        t.observe(&packet(&moving_bar(320, 240)));
        let held_at = t.estimate_px().unwrap();
        // The target vanishing in place: its footprint brightens. The estimate holds...
        let obs = t.observe(&packet(&footprint(320, 240, Polarity::On)));
        assert!(
            matches!(obs, Observation::Held { point_px, .. } if point_px == held_at),
            "{obs:?}"
        );
        assert!(t.polarity_pending());
        // ...and the silence after it confirms the one-sided change: a doubt, still held.
        let obs = t.observe(&packet(&[]));
        assert!(matches!(obs, Observation::Held { .. }), "{obs:?}");
        assert!(t.polarity_doubted());
        held_at
    }

    #[test]
    fn a_confirmed_one_sided_window_drops_the_track_unless_it_is_located_again() {
        let limit = EventTrackerConfig::paper().unconfirmed_hold_packets;
        let mut t = tracker();
        confirmed_then_one_sided(&mut t);
        // Nothing where it was: dropped when the hold runs out, named by the window.
        for _ in 2..limit {
            assert!(matches!(t.observe(&packet(&[])), Observation::Held { .. }));
        }
        let obs = t.observe(&packet(&[]));
        let Observation::Interrupted(TrackFault::OneSidedPolarity {
            majority_fraction,
            events,
        }) = obs
        else {
            panic!("{obs:?}")
        };
        assert!(
            majority_fraction >= 0.9 && events > 576,
            "{majority_fraction} {events}"
        );
        assert_eq!(t.estimate_px(), None, "searching again");
    }

    #[test]
    fn a_target_that_stopped_is_located_again_and_keeps_its_track() {
        let limit = EventTrackerConfig::paper().unconfirmed_hold_packets;
        let mut t = tracker();
        let held_at = confirmed_then_one_sided(&mut t);
        for _ in 0..3 {
            assert!(matches!(t.observe(&packet(&[])), Observation::Held { .. }));
        }
        // It moves again a few pixels from where it was held: located twice, confirmed.
        t.observe(&packet(&moving_bar(322, 241)));
        t.observe(&packet(&moving_bar(325, 241)));
        assert!(!t.polarity_doubted());
        for _ in 0..3 * limit {
            assert!(matches!(t.observe(&packet(&[])), Observation::Held { .. }));
        }
        let p = t.estimate_px().unwrap();
        assert!((p[0] - held_at[0]).abs() < 8.0, "{p:?} {held_at:?}");
    }

    #[test]
    fn a_stopped_target_that_settles_back_in_place_keeps_its_track() {
        let limit = EventTrackerConfig::paper().unconfirmed_hold_packets;
        let mut t = tracker();
        let held_at = confirmed_then_one_sided(&mut t);
        // It settles back where it stopped: its lower edge, a line, fires the opposite
        // polarity, as many events as the change had (a line is never support).
        let obs = t.observe(&packet(&edge(576, Polarity::Off)));
        assert!(matches!(obs, Observation::Held { .. }), "{obs:?}");
        // Rest long past the hold: the doubt is answered, never a drop.
        for _ in 0..2 * limit {
            let obs = t.observe(&packet(&[]));
            assert!(matches!(obs, Observation::Held { .. }), "{obs:?}");
        }
        assert!(!t.polarity_doubted());
        // Its creep's last packets doubt it again; the answer already seen still stands.
        let mut tail = footprint(320, 240, Polarity::On);
        tail.truncate(288);
        t.observe(&packet(&tail));
        t.observe(&packet(&[]));
        assert!(t.polarity_doubted());
        for _ in 0..2 * limit {
            let obs = t.observe(&packet(&[]));
            assert!(matches!(obs, Observation::Held { .. }), "{obs:?}");
        }
        assert_eq!(t.estimate_px(), Some(held_at));
    }

    /// A lower-edge line of `n` events at y = 245 around x = 320, one polarity.
    fn edge(n: usize, polarity: Polarity) -> Vec<(u16, u16, Polarity)> {
        (0..n)
            .map(|i| (296 + (i % 48) as u16, 245, polarity))
            .collect()
    }

    #[test]
    fn a_settle_split_by_locations_in_place_is_still_answered() {
        let limit = EventTrackerConfig::paper().unconfirmed_hold_packets;
        let mut t = tracker();
        let held_at = confirmed_then_one_sided(&mut t);
        // Located twice where it was held: confirmed, still settling.
        t.observe(&packet(&moving_bar(319, 240)));
        t.observe(&packet(&moving_bar(319, 240)));
        assert!(!t.polarity_doubted());
        let p = t.estimate_px().unwrap();
        assert!(
            (p[0] - held_at[0]).hypot(p[1] - held_at[1]) < 2.0,
            "{p:?} {held_at:?}"
        );
        // The settle's other half, doubted on its own, is the answer to the first.
        t.observe(&packet(&[]));
        t.observe(&packet(&footprint(320, 240, Polarity::Off)));
        t.observe(&packet(&[]));
        assert!(t.polarity_doubted());
        for _ in 0..2 * limit {
            let obs = t.observe(&packet(&[]));
            assert!(matches!(obs, Observation::Held { .. }), "{obs:?}");
        }
    }

    #[test]
    fn a_target_that_moved_on_must_be_answered_afresh() {
        let limit = EventTrackerConfig::paper().unconfirmed_hold_packets;
        let mut t = tracker();
        confirmed_then_one_sided(&mut t);
        // It moves on, located well away from where it was held...
        for cx in [326, 334, 342] {
            t.observe(&packet(&moving_bar(cx, 240)));
        }
        // ...and vanishes there: what fired at the first place answers nothing here.
        t.observe(&packet(&footprint(342, 240, Polarity::Off)));
        t.observe(&packet(&[]));
        assert!(t.polarity_doubted());
        assert_dropped_one_sided(&mut t, limit - 1, &[]);
    }

    #[test]
    fn a_trickle_of_opposite_events_does_not_answer_a_doubt() {
        let limit = EventTrackerConfig::paper().unconfirmed_hold_packets;
        let mut t = tracker();
        confirmed_then_one_sided(&mut t);
        // Four OFF events in place each packet, far more than the noise filter passes at rest:
        // less than a tenth of the change, no answer.
        let speck: Vec<_> = (0..4).map(|i| (318 + i, 240, Polarity::Off)).collect();
        assert_dropped_one_sided(&mut t, limit - 1, &speck);
    }

    /// Feeds `events` at most `packets` times: the track must be dropped as one-sided.
    fn assert_dropped_one_sided(
        t: &mut SupportTracker,
        packets: u32,
        events: &[(u16, u16, Polarity)],
    ) {
        for _ in 0..packets {
            if let Observation::Interrupted(fault) = t.observe(&packet(events)) {
                assert!(
                    matches!(fault, TrackFault::OneSidedPolarity { .. }),
                    "{fault:?}"
                );
                return;
            }
        }
        panic!("held after {packets} packets");
    }

    #[test]
    fn a_scene_that_stays_one_sided_cannot_keep_a_doubted_track() {
        let limit = EventTrackerConfig::paper().unconfirmed_hold_packets;
        let mut t = tracker();
        confirmed_then_one_sided(&mut t);
        // The footprint keeps brightening: every window one-sided, every packet held...
        let mut dropped_after = None;
        for k in 0..2 * limit {
            if let Observation::Interrupted(fault) =
                t.observe(&packet(&footprint(320, 240, Polarity::On)))
            {
                assert!(
                    matches!(fault, TrackFault::OneSidedPolarity { .. }),
                    "{fault:?}"
                );
                dropped_after = Some(k);
                break;
            }
        }
        // ...until the first window's hold runs out.
        assert_eq!(dropped_after, Some(limit - 2));
    }

    #[test]
    fn a_one_sided_outline_followed_by_the_opposite_polarity_is_motion() {
        let mut t = tracker();
        t.observe(&packet(&moving_bar(320, 240)));
        t.observe(&packet(&[]));
        // Motion onset of a straight-edged target: its trailing outline (an L) fires ON first.
        let mut onset: Vec<_> = (0..12).map(|dy| (296, 234 + dy, Polarity::On)).collect();
        onset.extend((0..48).map(|dx| (296 + dx, 234, Polarity::On)));
        assert!(matches!(
            t.observe(&packet(&onset)),
            Observation::Held { .. }
        ));
        // The leading outline follows with OFF: balanced, tracking goes on.
        let mut next: Vec<_> = (0..12).map(|dy| (344, 238 + dy, Polarity::Off)).collect();
        next.extend((0..48).map(|dx| (297 + dx, 246, Polarity::Off)));
        next.extend((0..12).map(|dy| (297, 235 + dy, Polarity::On)));
        let obs = t.observe(&packet(&next));
        assert!(matches!(obs, Observation::Located { .. }), "{obs:?}");
        assert!(!t.polarity_pending());
    }

    #[test]
    fn broad_scene_activity_interrupts() {
        let mut t = tracker();
        t.observe(&packet(&moving_bar(320, 240)));
        // A global change: a few events in every 32 px cell.
        let mut flash = moving_bar(320, 240);
        for cy in 0..15u16 {
            for cx in 0..20u16 {
                for k in 0..4 {
                    flash.push((cx * 32 + k, cy * 32 + 7, Polarity::On));
                }
            }
        }
        let obs = t.observe(&packet(&flash));
        assert!(matches!(
            obs,
            Observation::Interrupted(TrackFault::BroadActivity { active_cells: 300 })
        ));
        // Activity in a few far cells (another drone) is not broad.
        let mut t = tracker();
        t.observe(&packet(&moving_bar(320, 240)));
        let mut other = moving_bar(322, 240);
        other.extend((0..60).map(|i| (20 + i % 30, 400 + i / 30, Polarity::On)));
        assert!(matches!(
            t.observe(&packet(&other)),
            Observation::Located { .. }
        ));
    }

    #[test]
    fn bad_settings_are_rejected() {
        let mut c = EventTrackerConfig::paper();
        c.smoothing = 0.0;
        assert!(SupportTracker::new(c, 640, 480).is_err());
        let mut c = EventTrackerConfig::paper();
        c.one_sided_fraction = 0.4;
        assert!(c.validate().is_err());
        let mut c = EventTrackerConfig::paper();
        c.settle_px = f64::NAN;
        assert!(c.validate().is_err());
        assert!(SupportTracker::new(EventTrackerConfig::paper(), 0, 480).is_err());
    }
}
