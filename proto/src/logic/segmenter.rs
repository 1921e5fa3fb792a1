//! The shared NULL / motion segmenter used by the ideal, RGB and event receivers.
//!
//! Input: one image point per receiver step (or none), with a reliability flag and a gate the
//! receiver uses to veto NULL confirmation. Output: confirmed tokens with their sim-time stamps.
//!
//! - **NULL**: the point has stayed within `anchor_radius_px` of an anchor (the first sample of
//!   the rest) for `null_confirm_ns`, every sample reliable, and the receiver's gate is open at
//!   the confirming sample. Exactly one NULL is confirmed per rest period: the anchor stays
//!   fixed until the point leaves its radius.
//! - **Action**: the motion between two confirmed NULLs is the candidate path. It is classified
//!   with [`crate::classify`] when the second NULL is confirmed, and the action token (or
//!   `Unknown` for a rejected path) is emitted just before that NULL, with the same stamp.
//!   The path runs from the mean point of the previous rest, through every sample of the motion,
//!   up to the new rest's anchor, and ends at the mean point of the new rest. Using rest means
//!   instead of raw rest samples keeps tracker jitter during the 3 s hover out of the
//!   arc-length resampling, while still closing the path where the target settled (the anchor
//!   alone can sit up to one radius short of it).
//! - **Interruption**: a missing point, an unreliable sample, a gap between samples longer than
//!   `max_gap_ns`, or an explicit [`Segmenter::interrupt`] resets the rest timer and the
//!   candidate path and yields one `Unknown` per interruption episode, so the frame parser drops
//!   any incomplete frame. Motion that never comes to rest within `max_motion_ns` yields one
//!   `Unknown` as well (no symbol is that long).
//!
//! Motion seen before the first NULL after a reset is not a candidate: there is no delimiter in
//! front of it.
//!
//! **Late NULL** ([`SegmenterConfig::late_null`], the event receiver's setting): before the
//! first NULL, a rest that lasted `null_confirm_ns` while the receiver's gate was closed is held
//! as a *vetoed* NULL. If the gate opens while the point still rests there, the NULL is
//! confirmed then, as without the setting. If the point left first and the gate opens before
//! the next rest is confirmed, the vetoed NULL is emitted, with its own stamp, just before that
//! rest's action and NULL: the event receiver's gate opens on a closed path that *starts* at a
//! rest, which proves that rest was the target's (a receiver that locks on late still reads the
//! symbol that locked it). A second vetoed rest replaces the first; overlong motion or an
//! interruption drops it. Once emitted, a vetoed rest votes for the window's home too.
//!
//! **Late action** ([`SegmenterConfig::pooled_home_px`]): a path rejected only because its ends
//! do not meet, before the window has rests enough to pool a home, waits for the next confirmed
//! rest and is read at the home that rest pools. Its NULL is emitted at once (a delimiter never
//! waits on a later rest); the action follows with the next rest's tokens, with its own stamp
//! and flagged [`SegmentToken::late`], and [`crate::FrameParser::push_segment`] parses it
//! between the two NULLs it belongs between (`rest_home`).

use crate::logic::rest_home::{Reading, better};
pub use crate::logic::segment_sample::Sample;
use crate::{Classification, MatchSettings, Rejection, Token, classify};

/// Segmenter settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmenterConfig {
    /// A rest holds while the point stays within this distance of the rest's first sample.
    pub anchor_radius_px: f64,
    /// Rest duration that confirms a NULL.
    pub null_confirm_ns: u64,
    /// Larger spacing between consecutive samples is an input gap (an interruption).
    pub max_gap_ns: u64,
    /// Motion longer than this without coming to rest is not a symbol.
    pub max_motion_ns: u64,
    /// Template acceptance settings for candidate paths.
    pub match_settings: MatchSettings,
    /// Viewpoint rectification applied to every sample's point before anything else (`None`:
    /// the raw image trajectory).
    pub rectifier: Option<crate::rectify::Rectifier>,
    /// The camera at its home attitude, for undoing the airframe's turns
    /// ([`Segmenter::set_ego_rotation`]); `None`: the camera is not known and no turn is undone.
    pub home_camera: Option<crate::scene::ObserverCamera>,
    /// A rest vetoed by the receiver's gate before the first NULL becomes a NULL late when the
    /// gate opens before the next rest is confirmed (see the module docs).
    pub late_null: bool,
    /// The receiver holds its last estimate through a rest it has no evidence of (a still
    /// target makes no events), so a rest may sit where the target was last seen rather than
    /// where it stopped. When the point leaves a rest by a jump of more than the anchor radius
    /// in one step, either the rest was stale or the target was seen only once well under way:
    /// the symbol's path is classified both from the rest and from where the target reappeared,
    /// and the better match is kept.
    pub held_rests: bool,
    /// A path rejected only because its ends do not meet is read again with both ends at the
    /// window's home when both lie within this distance of it (`rest_home`); `None`: never.
    pub pooled_home_px: Option<f64>,
}

impl SegmenterConfig {
    /// RGB receiver: 15 px anchor, 3 s NULL, 25 Hz samples (a single missing frame is a gap).
    pub fn rgb() -> Self {
        Self {
            anchor_radius_px: 15.0,
            null_confirm_ns: 3_000_000_000,
            max_gap_ns: 60_000_000,
            max_motion_ns: 30_000_000_000,
            match_settings: MatchSettings::rgb(),
            rectifier: None,
            home_camera: None,
            late_null: false,
            held_rests: false,
            pooled_home_px: None,
        }
    }

    /// Event receiver: 20 px anchor, 3 s NULL, 25 Hz receiver steps, late NULLs (its gate opens
    /// on a closed path, after the rest the path started from).
    pub fn events() -> Self {
        Self {
            anchor_radius_px: 20.0,
            match_settings: MatchSettings::events(),
            late_null: true,
            held_rests: true,
            // Half a drone (24 px) + an ego-motion cell: docs/decisions/event-link-in-wind.md.
            pooled_home_px: Some(40.0),
            ..Self::rgb()
        }
    }

    /// The segmenter of `modality`'s receiver.
    pub fn for_modality(modality: crate::Modality) -> Self {
        match modality {
            crate::Modality::Events => Self::events(),
            crate::Modality::Rgb => Self::rgb(),
        }
    }

    /// These settings seen through `camera`'s rectification under `mode`.
    pub fn rectified(
        self,
        camera: crate::scene::ObserverCamera,
        mode: crate::rectify::Rectification,
    ) -> Self {
        Self {
            rectifier: crate::rectify::Rectifier::new(camera, mode),
            home_camera: Some(camera),
            ..self
        }
    }

    /// Rejects settings no receiver could run with.
    pub fn validate(&self) -> Result<(), SegmenterError> {
        let ok = self.anchor_radius_px.is_finite()
            && self.anchor_radius_px > 0.0
            && self.null_confirm_ns > 0
            && self.max_gap_ns > 0
            && self.max_motion_ns > 0;
        if ok {
            Ok(())
        } else {
            Err(SegmenterError::BadConfig {
                anchor_radius_px: self.anchor_radius_px,
                null_confirm_ns: self.null_confirm_ns,
                max_gap_ns: self.max_gap_ns,
                max_motion_ns: self.max_motion_ns,
            })
        }
    }
}

/// What broke continuity.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Interruption {
    /// Consecutive samples further apart than `max_gap_ns`.
    Gap { gap_ns: u64 },
    /// The receiver marked the sample unreliable.
    Unreliable,
    /// The receiver had no point.
    NoPoint,
    /// The caller reported missing input, a reset or a fault.
    External,
}

/// Why a token was emitted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TokenCause {
    /// A confirmed rest (NULL).
    Rest,
    /// An accepted candidate path.
    Classified(Classification),
    /// A candidate path the templates rejected (`Unknown`).
    Rejected(Rejection),
    /// Continuity broke (`Unknown`).
    Interrupted(Interruption),
    /// Motion went on for longer than `max_motion_ns` (`Unknown`).
    Overlong { motion_ns: u64 },
    /// Read by a receiver outside the segmenter (a token-level or full receiver plug-in).
    External,
}

/// A token confirmed by the segmenter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentToken {
    pub token: Token,
    pub stamp_ns: u64,
    pub cause: TokenCause,
    /// An action read after the NULL that follows it was emitted (it waited for a home,
    /// [`SegmenterConfig::pooled_home_px`]): it belongs between the last two NULLs emitted,
    /// where [`crate::FrameParser::push_segment`] puts it.
    pub late: bool,
}

/// Malformed input.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum SegmenterError {
    #[error("sample stamp {stamp_ns} ns is not after the previous one ({previous_ns} ns)")]
    NonMonotonicStamp { previous_ns: u64, stamp_ns: u64 },
    #[error("sample point {point_px:?} is not finite")]
    NonFinitePoint { point_px: [f64; 2] },
    #[error(
        "invalid segmenter settings: anchor radius {anchor_radius_px} px, NULL after \
         {null_confirm_ns} ns, gap {max_gap_ns} ns, motion {max_motion_ns} ns (all must be positive)"
    )]
    BadConfig {
        anchor_radius_px: f64,
        null_confirm_ns: u64,
        max_gap_ns: u64,
        max_motion_ns: u64,
    },
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Anchor {
    point_px: [f64; 2],
    stamp_ns: u64,
    /// Index of the anchor sample in the candidate path (meaningful after a NULL only).
    path_index: usize,
}

/// Incremental segmenter for one observer.
#[derive(Debug, Clone)]
pub struct Segmenter {
    config: SegmenterConfig,
    last_stamp_ns: Option<u64>,
    interrupted: bool,
    anchor: Option<Anchor>,
    /// Sum and count of the samples of the current rest window (anchor onwards, in radius).
    rest_sum_px: [f64; 2],
    rest_count: u32,
    /// NULL already confirmed for the current anchor.
    rested: bool,
    /// A NULL has been confirmed since the last reset, so motion is a candidate symbol.
    after_null: bool,
    motion_start_ns: Option<u64>,
    path_px: Vec<[f64; 2]>,
    /// Reliable samples since the last interruption, at most one NULL-confirmation span old:
    /// a new rest starts at the earliest of them that is already within the anchor radius of
    /// where the target now is, so the rest timer does not depend on where, inside the radius,
    /// a lagging tracker happened to cross its edge.
    recent: std::collections::VecDeque<(u64, [f64; 2])>,
    /// How far the observer's airframe has turned from its home attitude, undone on every
    /// sample's point before rectification (`None`: not turned, or not known).
    ego: Option<crate::stabilise::EgoRotation>,
    /// Stamp and rest of the vetoed NULL held as the current delimiter
    /// ([`SegmenterConfig::late_null`]).
    vetoed_null: Option<(u64, [f64; 2])>,
    /// The candidate path left its rest by a jump ([`SegmenterConfig::held_rests`]).
    stale_rest: bool,
    home: crate::logic::rest_home::RestHome,
}

impl Segmenter {
    pub fn new(config: SegmenterConfig) -> Result<Self, SegmenterError> {
        config.validate()?;
        Ok(Self::fresh(config))
    }

    fn fresh(config: SegmenterConfig) -> Self {
        Self {
            config,
            last_stamp_ns: None,
            interrupted: false,
            anchor: None,
            rest_sum_px: [0.0; 2],
            rest_count: 0,
            rested: false,
            after_null: false,
            motion_start_ns: None,
            path_px: Vec::new(),
            recent: std::collections::VecDeque::new(),
            ego: None,
            vetoed_null: None,
            stale_rest: false,
            home: Default::default(),
        }
    }

    /// Forgets everything, including the last stamp, without emitting a token (round reset).
    /// The airframe's attitude is a fact of the sensor, not of the decoding: it is kept.
    pub fn reset(&mut self) {
        let ego = self.ego;
        *self = Self::fresh(self.config);
        self.ego = ego;
    }

    /// How far the observer's airframe has turned from its home attitude from the next sample
    /// on (`None`: not turned). Needs the home camera ([`SegmenterConfig::rectified`]); without
    /// it the rotation is ignored.
    pub fn set_ego_rotation(&mut self, ego: Option<crate::stabilise::EgoRotation>) {
        self.ego = ego;
    }

    pub fn config(&self) -> &SegmenterConfig {
        &self.config
    }

    /// True while the current rest has been confirmed as NULL.
    pub fn is_resting(&self) -> bool {
        self.rested && self.vetoed_null.is_none()
    }

    /// Stamp of the last sample or interruption.
    pub fn last_stamp_ns(&self) -> Option<u64> {
        self.last_stamp_ns
    }

    /// Consumes one sample; returns the tokens it confirms (0, 1 or 2 — an action and its NULL,
    /// or an interruption — and before them a vetoed NULL or a late action when one is
    /// released). Malformed samples are rejected and leave the state unchanged.
    pub fn push(&mut self, sample: Sample) -> Result<Vec<SegmentToken>, SegmenterError> {
        if let Some(previous_ns) = self.last_stamp_ns
            && sample.stamp_ns <= previous_ns
        {
            return Err(SegmenterError::NonMonotonicStamp {
                previous_ns,
                stamp_ns: sample.stamp_ns,
            });
        }
        if let Some(p) = sample.point_px
            && !(p[0].is_finite() && p[1].is_finite())
        {
            return Err(SegmenterError::NonFinitePoint { point_px: p });
        }
        let sample = match (&self.ego, &self.config.home_camera) {
            (Some(ego), Some(home)) => crate::stabilise::stabilised_sample(home, ego, sample),
            _ => sample,
        };
        let sample = self.config.rectifier.map_or(sample, |r| r.sample(sample));
        let mut out = Vec::new();
        let stamp_ns = sample.stamp_ns;
        if let Some(previous_ns) = self.last_stamp_ns
            && stamp_ns - previous_ns > self.config.max_gap_ns
        {
            out.extend(self.break_continuity(
                stamp_ns,
                Interruption::Gap {
                    gap_ns: stamp_ns - previous_ns,
                },
            ));
        }
        self.last_stamp_ns = Some(stamp_ns);
        let p = match (sample.point_px, sample.reliable) {
            (Some(p), true) => p,
            (None, _) => {
                out.extend(self.break_continuity(stamp_ns, Interruption::NoPoint));
                return Ok(out);
            }
            (Some(_), false) => {
                out.extend(self.break_continuity(stamp_ns, Interruption::Unreliable));
                return Ok(out);
            }
        };
        self.interrupted = false;
        self.recent.push_back((stamp_ns, p));
        while self
            .recent
            .front()
            .is_some_and(|&(t, _)| stamp_ns - t > self.config.null_confirm_ns)
        {
            self.recent.pop_front();
        }
        let radius_px = self.config.anchor_radius_px;
        if self.rested {
            if self
                .anchor
                .is_some_and(|a| dist(a.point_px, p) <= radius_px)
            {
                self.stay_at_rest(stamp_ns, p, sample.null_allowed, &mut out);
                return Ok(out);
            }
            self.leave_rest(stamp_ns, p);
        }
        if self.after_null {
            self.path_px.push(p);
        }
        // The rest candidate is anchored on where the target is now: it started at the earliest
        // recent sample from which every later one lies within the anchor radius of this point.
        // Anchoring on the current point (not on wherever an earlier candidate happened to
        // begin) makes the rest start a property of the trajectory's final approach alone, so
        // receivers whose estimates differ by a few pixels confirm their NULLs together.
        let (mut start_ns, mut sum_px, mut count) = (stamp_ns, p, 1u32);
        for &(t, q) in self.recent.iter().rev().skip(1) {
            if dist(q, p) > radius_px {
                break;
            }
            start_ns = t;
            sum_px = [sum_px[0] + q[0], sum_px[1] + q[1]];
            count += 1;
        }
        if self.after_null
            && let Some(motion_ns) = self.motion_start_ns.map(|m| start_ns.saturating_sub(m))
            && motion_ns > self.config.max_motion_ns
        {
            // After a vetoed NULL no delimiter was ever emitted: nothing to report.
            if self.vetoed_null.take().is_none() {
                out.push(SegmentToken {
                    token: Token::Unknown,
                    stamp_ns,
                    cause: TokenCause::Overlong { motion_ns },
                    late: false,
                });
            }
            self.after_null = false;
            self.motion_start_ns = None;
            self.path_px.clear();
            self.home.drop_waiting();
        }
        let anchor = Anchor {
            point_px: p,
            stamp_ns: start_ns,
            path_index: self.path_px.len().saturating_sub(count as usize),
        };
        self.anchor = Some(anchor);
        self.rest_sum_px = sum_px;
        self.rest_count = count;
        if stamp_ns - start_ns >= self.config.null_confirm_ns {
            if sample.null_allowed {
                self.confirm_null(stamp_ns, anchor, &mut out);
            } else if self.config.late_null && (!self.after_null || self.vetoed_null.is_some()) {
                self.hold_vetoed_null(stamp_ns);
            }
        }
        Ok(out)
    }

    /// Reports missing input (a lost packet, a fault, a reset) at `stamp_ns`: one `Unknown`
    /// token unless continuity is already broken.
    pub fn interrupt(&mut self, stamp_ns: u64) -> Result<Option<SegmentToken>, SegmenterError> {
        if let Some(previous_ns) = self.last_stamp_ns
            && stamp_ns < previous_ns
        {
            return Err(SegmenterError::NonMonotonicStamp {
                previous_ns,
                stamp_ns,
            });
        }
        self.last_stamp_ns = Some(stamp_ns);
        Ok(self.break_continuity(stamp_ns, Interruption::External))
    }

    fn break_continuity(&mut self, stamp_ns: u64, why: Interruption) -> Option<SegmentToken> {
        self.anchor = None;
        self.recent.clear();
        self.rested = false;
        self.after_null = false;
        self.motion_start_ns = None;
        self.path_px.clear();
        self.rest_count = 0;
        self.vetoed_null = None;
        self.home.drop_waiting();
        if self.interrupted {
            return None;
        }
        self.interrupted = true;
        Some(SegmentToken {
            token: Token::Unknown,
            stamp_ns,
            cause: TokenCause::Interrupted(why),
            late: false,
        })
    }

    /// A sample within the confirmed (or vetoed) rest's radius.
    fn stay_at_rest(
        &mut self,
        stamp_ns: u64,
        p: [f64; 2],
        null_allowed: bool,
        out: &mut Vec<SegmentToken>,
    ) {
        self.rest_sum_px = [self.rest_sum_px[0] + p[0], self.rest_sum_px[1] + p[1]];
        self.rest_count = self.rest_count.saturating_add(1);
        if null_allowed && let Some((_, rest_px)) = self.vetoed_null.take() {
            // The gate opened on the vetoed rest itself: an ordinary NULL, now.
            self.home.record(rest_px);
            out.push(null_token(stamp_ns));
        }
    }

    /// The target left its confirmed rest: motion starts at `p`.
    fn leave_rest(&mut self, stamp_ns: u64, p: [f64; 2]) {
        self.rested = false;
        self.stale_rest = self.config.held_rests
            && self.recent.len() >= 2
            && dist(self.recent[self.recent.len() - 2].1, p) > self.config.anchor_radius_px;
        // Samples of the confirmed rest must never start the next one.
        self.recent.clear();
        self.recent.push_back((stamp_ns, p));
        self.motion_start_ns = Some(stamp_ns);
        self.path_px.clear();
        self.path_px.push(self.rest_mean());
    }

    /// The current rest would be a NULL but for the gate: it delimits what follows, unemitted.
    fn hold_vetoed_null(&mut self, stamp_ns: u64) {
        self.vetoed_null = Some((stamp_ns, self.rest_mean()));
        self.rested = true;
        self.after_null = true;
        self.motion_start_ns = None;
        self.path_px.clear();
    }

    fn confirm_null(&mut self, stamp_ns: u64, anchor: Anchor, out: &mut Vec<SegmentToken>) {
        if let Some((vetoed_ns, rest_px)) = self.vetoed_null.take() {
            // Proved the target's by the path that opened the gate: it votes for home too.
            self.home.record(rest_px);
            out.push(null_token(vetoed_ns));
        }
        self.home.record(self.rest_mean()); // read only with `pooled_home_px`
        let (reach_px, settings) = (self.config.pooled_home_px, &self.config.match_settings);
        if let Some((reading, read_ns)) = self.home.take_waiting(reach_px, settings) {
            out.push(SegmentToken {
                late: true,
                ..action_token(reading, read_ns)
            });
        }
        if self.after_null && self.motion_start_ns.is_some() {
            let mut candidate = self.path_px[..=anchor.path_index].to_vec();
            candidate.push(self.rest_mean());
            let mut classified = classify(&candidate, settings);
            if self.stale_rest && candidate.len() > 2 {
                classified = better(classified, classify(&candidate[1..], settings));
            }
            let reading = self
                .home
                .read(candidate, classified, stamp_ns, reach_px, settings);
            out.extend(reading.map(|r| action_token(r, stamp_ns)));
        }
        out.push(null_token(stamp_ns));
        self.rested = true;
        self.after_null = true;
        self.motion_start_ns = None;
        self.path_px.clear();
    }

    fn rest_mean(&self) -> [f64; 2] {
        let n = f64::from(self.rest_count.max(1));
        [self.rest_sum_px[0] / n, self.rest_sum_px[1] / n]
    }
}

/// The token of a symbol's reading, stamped with the NULL it precedes.
fn action_token(reading: Reading, stamp_ns: u64) -> SegmentToken {
    let (token, cause) = match reading {
        Ok(c) => (c.action.token(), TokenCause::Classified(c)),
        Err(r) => (Token::Unknown, TokenCause::Rejected(r)),
    };
    SegmentToken {
        token,
        stamp_ns,
        cause,
        late: false,
    }
}

fn null_token(stamp_ns: u64) -> SegmentToken {
    SegmentToken {
        token: Token::Null,
        stamp_ns,
        cause: TokenCause::Rest,
        late: false,
    }
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::Action;

    pub const PERIOD_NS: u64 = 40_000_000;
    pub const S: u64 = 1_000_000_000;
    pub const CENTRE: [f64; 2] = [320.0, 240.0];

    /// A receiver's sample stream, built step by step at 25 Hz.
    pub struct Script {
        pub samples: Vec<Sample>,
        pub next_ns: u64,
    }

    impl Script {
        pub fn new(start_ns: u64) -> Self {
            Self {
                samples: Vec::new(),
                next_ns: start_ns,
            }
        }

        fn push(&mut self, s: Sample) {
            self.samples.push(s);
            self.next_ns += PERIOD_NS;
        }

        /// Hover at `p` for `duration_ns` with ±2 px deterministic jitter.
        pub fn hover(&mut self, p: [f64; 2], duration_ns: u64) -> &mut Self {
            for k in 0..duration_ns / PERIOD_NS {
                let j = [((k * 7) % 5) as f64 - 2.0, ((k * 3) % 5) as f64 - 2.0];
                self.push(Sample::tracked(self.next_ns, [p[0] + j[0], p[1] + j[1]]));
            }
            self
        }

        /// From a 4 s hover at home, each of `actions` drawn at `scale_px` and followed by a
        /// 4 s hover at home.
        pub fn symbols(&mut self, actions: &[Action], scale_px: f64) -> &mut Self {
            self.hover(CENTRE, 4 * S);
            for &action in actions {
                self.draw(action, CENTRE, scale_px, 4 * S)
                    .hover(CENTRE, 4 * S);
            }
            self
        }

        /// Draw `action`'s image polyline at `scale_px` from `p` at constant speed.
        pub fn draw(
            &mut self,
            action: Action,
            p: [f64; 2],
            scale_px: f64,
            duration_ns: u64,
        ) -> &mut Self {
            let poly: Vec<[f64; 2]> = action
                .image_polyline()
                .iter()
                .map(|q| [p[0] + scale_px * q[0], p[1] + scale_px * q[1]])
                .collect();
            self.polyline(&poly, duration_ns)
        }

        /// Traverse `poly` at constant speed in `duration_ns` (end point excluded).
        pub fn polyline(&mut self, poly: &[[f64; 2]], duration_ns: u64) -> &mut Self {
            let lens: Vec<f64> = poly.windows(2).map(|w| dist(w[0], w[1])).collect();
            let total: f64 = lens.iter().sum();
            let n = duration_ns / PERIOD_NS;
            for k in 0..n {
                let mut d = total * k as f64 / n as f64;
                let mut seg = 0;
                while seg + 1 < lens.len() && d > lens[seg] {
                    d -= lens[seg];
                    seg += 1;
                }
                let t = if lens[seg] > 0.0 { d / lens[seg] } else { 0.0 };
                let (a, b) = (poly[seg], poly[seg + 1]);
                self.push(Sample::tracked(
                    self.next_ns,
                    [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])],
                ));
            }
            self
        }

        pub fn sample(&mut self, s: impl Fn(u64) -> Sample) -> &mut Self {
            let s = s(self.next_ns);
            self.push(s);
            self
        }
    }

    pub fn run(seg: &mut Segmenter, samples: &[Sample]) -> Vec<SegmentToken> {
        samples.iter().flat_map(|&s| seg.push(s).unwrap()).collect()
    }

    fn tokens(t: &[SegmentToken]) -> Vec<Token> {
        t.iter().map(|t| t.token).collect()
    }

    fn rgb() -> Segmenter {
        Segmenter::new(SegmenterConfig::rgb()).unwrap()
    }

    #[test]
    fn a_still_point_confirms_exactly_one_null_after_3_s() {
        let mut sc = Script::new(S);
        sc.hover(CENTRE, 60 * S);
        let out = run(&mut rgb(), &sc.samples);
        assert_eq!(tokens(&out), vec![Token::Null]);
        assert_eq!(out[0].stamp_ns, 4 * S, "3 s after the first sample");
        assert_eq!(out[0].cause, TokenCause::Rest);
    }

    #[test]
    fn leaving_the_anchor_radius_restarts_the_rest_timer() {
        for (jump_px, want_ns) in [(10.0, 3 * S), (20.0, 5 * S)] {
            let mut sc = Script::new(0);
            sc.hover(CENTRE, 2 * S)
                .hover([CENTRE[0] + jump_px, CENTRE[1]], 10 * S);
            // The jittered samples sit up to 2√2 px off; a 10 px jump stays within 15 px.
            let out = run(&mut rgb(), &sc.samples);
            assert_eq!(tokens(&out), vec![Token::Null], "jump {jump_px}");
            assert_eq!(out[0].stamp_ns, want_ns, "jump {jump_px}");
        }
        // The event receiver's 20 px anchor tolerates a step the RGB one does not: with the
        // jitter, the points after a 15.5 px step lie 15.5–19.9 px from the anchor.
        let mut sc = Script::new(0);
        sc.hover(CENTRE, 2 * S)
            .hover([CENTRE[0] + 15.5, CENTRE[1]], 10 * S);
        let rgb_out = run(&mut rgb(), &sc.samples);
        let ev_out = run(
            &mut Segmenter::new(SegmenterConfig::events()).unwrap(),
            &sc.samples,
        );
        // The RGB rest restarts at the step, give or take the one jittered sample before it
        // that already lay within 15 px of where the target settled.
        assert!(
            (4_900_000_000..=5 * S).contains(&rgb_out[0].stamp_ns),
            "{rgb_out:?}"
        );
        assert_eq!(ev_out[0].stamp_ns, 3 * S);
    }

    #[test]
    fn the_rest_starts_where_the_final_approach_entered_the_radius_whatever_came_before() {
        // Two receivers see the same slow 20 px/s approach to the same hover point; one saw it
        // from 10 px further out. A rest anchored on an earlier candidate would begin wherever
        // the chain of candidates happened to fall (≈ 0.5 s apart here); anchored on the
        // current point it begins 20 px out in both.
        let end_ns = 20 * S;
        let approach = |from_px: f64| {
            let mut samples = Vec::new();
            let travel_ns = (from_px / 20.0 * 1e9) as u64;
            let mut t = end_ns - travel_ns;
            while t < end_ns + 6 * S {
                let left_px = from_px * (end_ns.saturating_sub(t)) as f64 / travel_ns as f64;
                samples.push(Sample::tracked(t, [CENTRE[0] + left_px, CENTRE[1]]));
                t += PERIOD_NS;
            }
            samples
        };
        let nulls = |from_px: f64| {
            let out = run(
                &mut Segmenter::new(SegmenterConfig::events()).unwrap(),
                &approach(from_px),
            );
            assert_eq!(tokens(&out), vec![Token::Null], "from {from_px} px");
            out[0].stamp_ns
        };
        let want_ns = end_ns - S + 3 * S;
        // 20 px out at 20 px/s is 1 s before arrival; the NULL follows 3 s after that (the
        // farther approach is sampled at other instants: one sample period of play).
        for from_px in [200.0, 210.0] {
            let null_ns = nulls(from_px);
            assert!(
                null_ns.abs_diff(want_ns) <= PERIOD_NS,
                "from {from_px} px: {null_ns}"
            );
        }
    }

    /// Three symbols at `scale_px` from home, the last one's rest read at `end_px`.
    fn three_symbols_ending_at(end_px: [f64; 2], scale_px: f64) -> Vec<Sample> {
        let mut sc = Script::new(0);
        sc.symbols(&[Action::Bit0, Action::Bit1], scale_px)
            .draw(Action::Bit0, CENTRE, scale_px, 4 * S)
            .hover(end_px, 4 * S);
        sc.samples
    }

    fn events(reach_px: Option<f64>) -> Segmenter {
        Segmenter::new(SegmenterConfig {
            pooled_home_px: reach_px,
            ..SegmenterConfig::events()
        })
        .unwrap()
    }

    #[test]
    fn a_rest_read_short_of_home_is_closed_at_the_windows_home() {
        let short = [CENTRE[0] + 14.0, CENTRE[1]];
        let out = run(&mut events(None), &three_symbols_ending_at(short, 46.0));
        assert_eq!(out[5].token, Token::Unknown, "{out:?}");
        assert!(
            matches!(
                out[5].cause,
                TokenCause::Rejected(Rejection::NotClosed { .. })
            ),
            "{:?}",
            out[5]
        );
        let out = run(
            &mut events(Some(20.0)),
            &three_symbols_ending_at(short, 46.0),
        );
        assert_eq!(
            tokens(&out),
            [
                Token::Null,
                Token::Bit0,
                Token::Null,
                Token::Bit1,
                Token::Null,
                Token::Bit0,
                Token::Null
            ]
        );
        // A rest beyond the reach of home is not home: the path stays open.
        let far = [CENTRE[0] + 24.0, CENTRE[1]];
        let out = run(&mut events(Some(20.0)), &three_symbols_ending_at(far, 46.0));
        assert_eq!(out[5].token, Token::Unknown, "{out:?}");
        // Closed paths read as before: the same tokens with the home on or off.
        let closed = three_symbols_ending_at(CENTRE, 46.0);
        assert_eq!(
            run(&mut events(Some(20.0)), &closed),
            run(&mut events(None), &closed)
        );
    }

    /// Two bits, then END flown at `scale_px` whose final approach to home is seen only up to
    /// `short_px` before home (the receiver holds its last sighting through the rest).
    fn end_lost_short_of_home(scale_px: f64, short_px: f64) -> Vec<Sample> {
        let mut sc = Script::new(0);
        sc.symbols(&[Action::Bit0, Action::Bit1], 46.0);
        let mut poly: Vec<[f64; 2]> = Action::End
            .image_polyline()
            .iter()
            .map(|q| [CENTRE[0] + scale_px * q[0], CENTRE[1] + scale_px * q[1]])
            .collect();
        let n = poly.len();
        let (a, b) = (poly[n - 2], poly[n - 1]);
        let last_px = dist(a, b);
        assert!(last_px > short_px, "END's last leg is {last_px} px");
        let t = 1.0 - short_px / last_px;
        poly[n - 1] = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
        sc.polyline(&poly, 6 * S).hover(poly[n - 1], 4 * S);
        sc.samples
    }

    #[test]
    fn an_arrival_lost_within_the_reach_of_home_is_closed_at_home() {
        let end = |reach_px, short_px| {
            let out = run(
                &mut events(reach_px),
                &end_lost_short_of_home(70.0, short_px),
            );
            out[5].token
        };
        let reach = SegmenterConfig::events().pooled_home_px;
        assert_eq!(end(None, 0.0), Token::End);
        assert_eq!(end(None, 34.0), Token::Unknown);
        assert_eq!(end(reach, 34.0), Token::End);
        // Beyond the reach the rest is somewhere else: the path stays open.
        assert_eq!(end(reach, 50.0), Token::Unknown);
    }

    #[test]
    fn a_symbol_between_two_nulls_is_classified_before_its_null() {
        for action in Action::ALL {
            let mut sc = Script::new(0);
            sc.hover(CENTRE, 4 * S)
                .draw(action, CENTRE, 90.0, 4 * S)
                .hover(CENTRE, 4 * S);
            let out = run(&mut rgb(), &sc.samples);
            assert_eq!(
                tokens(&out),
                vec![Token::Null, action.token(), Token::Null],
                "{action}"
            );
            assert_eq!(out[1].stamp_ns, out[2].stamp_ns);
            // The rest starts once the point is within 15 px of where it settles, just before
            // the drawing ends at 8 s, and is confirmed 3 s later.
            assert!(
                (10_700_000_000..=11 * S).contains(&out[2].stamp_ns),
                "{action}: {out:?}"
            );
            let TokenCause::Classified(c) = out[1].cause else {
                panic!("{:?}", out[1])
            };
            assert!(c.error < 0.03 && c.closure < 0.03, "{action}: {c:?}");
        }
    }

    #[test]
    fn motion_before_the_first_null_is_not_a_candidate() {
        let mut sc = Script::new(0);
        sc.draw(Action::Start, CENTRE, 90.0, 4 * S)
            .hover(CENTRE, 4 * S);
        assert_eq!(tokens(&run(&mut rgb(), &sc.samples)), vec![Token::Null]);
    }

    #[test]
    fn lost_or_unreliable_input_interrupts_once_and_discards_the_path() {
        let mut sc = Script::new(0);
        sc.hover(CENTRE, 4 * S)
            .draw(Action::Bit0, CENTRE, 90.0, 2 * S);
        for k in 0..5 {
            if k % 2 == 0 {
                sc.sample(|t| Sample {
                    reliable: false,
                    ..Sample::tracked(t, CENTRE)
                });
            } else {
                sc.sample(Sample::lost);
            }
        }
        let resume_ns = sc.next_ns;
        sc.draw(Action::Bit0, CENTRE, 90.0, 2 * S)
            .hover(CENTRE, 4 * S);
        let out = run(&mut rgb(), &sc.samples);
        assert_eq!(tokens(&out), vec![Token::Null, Token::Unknown, Token::Null]);
        assert_eq!(
            out[1].cause,
            TokenCause::Interrupted(Interruption::Unreliable)
        );
        assert_eq!(out[1].stamp_ns, 6 * S);
        // The rest after the interruption needs its own full 3 s and yields no symbol.
        assert!(out[2].stamp_ns >= resume_ns + 3 * S);
    }

    #[test]
    fn an_input_gap_interrupts_even_during_a_confirmed_rest() {
        let mut sc = Script::new(0);
        sc.hover(CENTRE, 4 * S);
        sc.next_ns += PERIOD_NS; // one missing sample
        sc.hover(CENTRE, 4 * S);
        let out = run(&mut rgb(), &sc.samples);
        assert_eq!(tokens(&out), vec![Token::Null, Token::Unknown, Token::Null]);
        assert_eq!(
            out[1].cause,
            TokenCause::Interrupted(Interruption::Gap {
                gap_ns: 2 * PERIOD_NS
            })
        );
        assert_eq!(out[2].stamp_ns, out[1].stamp_ns + 3 * S);
    }

    #[test]
    fn explicit_interrupts_count_once_per_episode() {
        let mut seg = rgb();
        let mut sc = Script::new(0);
        sc.hover(CENTRE, 4 * S);
        run(&mut seg, &sc.samples);
        let t = sc.next_ns;
        let first = seg.interrupt(t).unwrap().expect("one Unknown");
        assert_eq!(first.cause, TokenCause::Interrupted(Interruption::External));
        assert_eq!(seg.interrupt(t).unwrap(), None);
        assert!(matches!(
            seg.interrupt(t - 1),
            Err(SegmenterError::NonMonotonicStamp { .. })
        ));
    }

    #[test]
    fn a_closed_gate_defers_the_null_without_resetting_the_rest() {
        let gated = |open_after_ns: u64| {
            let mut sc = Script::new(0);
            sc.hover(CENTRE, 10 * S);
            for s in &mut sc.samples {
                s.null_allowed = s.stamp_ns >= open_after_ns;
            }
            run(&mut rgb(), &sc.samples)
        };
        let out = gated(5 * S);
        assert_eq!(tokens(&out), vec![Token::Null]);
        assert_eq!(out[0].stamp_ns, 5 * S);
        assert!(gated(u64::MAX).is_empty());
        assert_eq!(gated(0)[0].stamp_ns, 3 * S);
    }

    #[test]
    fn overlong_motion_is_unknown_and_not_classified_later() {
        let mut sc = Script::new(0);
        sc.hover(CENTRE, 4 * S);
        for _ in 0..10 {
            sc.draw(Action::End, CENTRE, 90.0, 4 * S);
        }
        sc.hover(CENTRE, 4 * S);
        let out = run(&mut rgb(), &sc.samples);
        assert_eq!(tokens(&out), vec![Token::Null, Token::Unknown, Token::Null]);
        assert!(matches!(out[1].cause, TokenCause::Overlong { motion_ns } if motion_ns > 30 * S));
    }

    /// `sc`'s samples with the gate closed before `open_ns`.
    fn gated(sc: &Script, open_ns: u64) -> Vec<Sample> {
        let gate = |s: &Sample| Sample {
            null_allowed: s.stamp_ns >= open_ns,
            ..*s
        };
        sc.samples.iter().map(gate).collect()
    }

    #[test]
    fn a_rest_vetoed_by_the_gate_delimits_the_symbol_that_opened_it() {
        // Rest 4 s (gate closed), START, rest: the gate opens 1.5 s into the second rest, as
        // the event receiver's does when the closed path settles.
        let mut sc = Script::new(0);
        sc.hover(CENTRE, 4 * S)
            .draw(Action::Start, CENTRE, 90.0, 4 * S)
            .hover(CENTRE, 5 * S);
        let samples = gated(&sc, 9_500_000_000);
        let out = run(
            &mut Segmenter::new(SegmenterConfig::events()).unwrap(),
            &samples,
        );
        assert_eq!(
            tokens(&out),
            vec![Token::Null, Token::Start, Token::Null],
            "{out:?}"
        );
        assert_eq!(
            out[0].stamp_ns,
            3 * S,
            "the vetoed NULL keeps its own stamp"
        );
        assert!(out[1].stamp_ns > 9_500_000_000 && out[1].stamp_ns == out[2].stamp_ns);
        // Without late NULLs the symbol is motion before the first NULL.
        let rgb_like = SegmenterConfig {
            late_null: false,
            ..SegmenterConfig::events()
        };
        let out = run(&mut Segmenter::new(rgb_like).unwrap(), &samples);
        assert_eq!(tokens(&out), vec![Token::Null]);
    }

    #[test]
    fn a_gate_opening_on_the_vetoed_rest_itself_confirms_it_then() {
        let mut sc = Script::new(0);
        sc.hover(CENTRE, 8 * S);
        for late_null in [false, true] {
            let config = SegmenterConfig {
                late_null,
                ..SegmenterConfig::events()
            };
            let out = run(&mut Segmenter::new(config).unwrap(), &gated(&sc, 5 * S));
            assert_eq!(tokens(&out), vec![Token::Null], "late_null {late_null}");
            assert_eq!(out[0].stamp_ns, 5 * S, "late_null {late_null}");
        }
    }

    #[test]
    fn a_vetoed_rest_is_replaced_by_the_next_and_dropped_by_overlong_motion() {
        let seg = || Segmenter::new(SegmenterConfig::events()).unwrap();
        // Two vetoed rests: the symbol after the second one is the candidate.
        let mut sc = Script::new(0);
        sc.symbols(&[Action::End], 90.0)
            .draw(Action::Bit1, CENTRE, 90.0, 4 * S)
            .hover(CENTRE, 5 * S);
        let out = run(&mut seg(), &gated(&sc, 18 * S));
        assert_eq!(tokens(&out), vec![Token::Null, Token::Bit1, Token::Null]);
        assert!((10 * S..12 * S).contains(&out[0].stamp_ns), "{out:?}");
        // Motion that never settles drops the vetoed rest without a token.
        let mut sc = Script::new(0);
        sc.hover(CENTRE, 4 * S);
        for _ in 0..10 {
            sc.draw(Action::End, CENTRE, 90.0, 4 * S);
        }
        sc.hover(CENTRE, 5 * S);
        let out = run(&mut seg(), &gated(&sc, 44 * S));
        assert_eq!(tokens(&out), vec![Token::Null]);
        assert!(out[0].stamp_ns > 44 * S, "{out:?}");
    }

    #[test]
    fn a_rest_left_by_a_jump_is_read_from_the_rest_or_from_where_the_target_reappeared() {
        let poly: Vec<[f64; 2]> = Action::Start
            .image_polyline()
            .iter()
            .map(|q| [CENTRE[0] + 90.0 * q[0], CENTRE[1] + 90.0 * q[1]])
            .collect();
        // The symbol spans 173 px: 45 px at either end is beyond the 0.2 closure limit.
        let along = 45.0 / dist(poly[0], poly[1]);
        let mut later = poly.clone();
        later[0] = [
            poly[0][0] + along * (poly[1][0] - poly[0][0]),
            poly[0][1] + along * (poly[1][1] - poly[0][1]),
        ];
        let offset = [CENTRE[0] - 45.0, CENTRE[1]];
        // (where the receiver held the rest, the path it saw): a stale hold 45 px off the
        // start, then the whole symbol; a true rest, then the symbol seen only 45 px under way
        // (a jump too, which must not cost the symbol).
        for (held, drawn) in [(offset, &poly), (poly[0], &later)] {
            let mut sc = Script::new(0);
            sc.hover(held, 4 * S)
                .polyline(drawn, 4 * S)
                .hover(*poly.last().unwrap(), 4 * S);
            for held_rests in [false, true] {
                // Without a pooled home, whose reading would wait for a third rest.
                let config = SegmenterConfig {
                    held_rests,
                    pooled_home_px: None,
                    ..SegmenterConfig::events()
                };
                let out = run(&mut Segmenter::new(config).unwrap(), &sc.samples);
                let read = tokens(&out);
                // A true rest is right whichever way the symbol was seen: only a stale hold
                // needs the second reading.
                if held_rests || held == poly[0] {
                    assert_eq!(read[1], Token::Start, "held {held:?}: {out:?}");
                } else {
                    assert_eq!(read[1], Token::Unknown, "held {held:?}: {out:?}");
                }
            }
        }
    }

    #[test]
    fn a_rejected_path_is_unknown_followed_by_its_null() {
        let mut sc = Script::new(0);
        let wiggle = [CENTRE, [CENTRE[0] + 22.0, CENTRE[1]], CENTRE];
        sc.hover(CENTRE, 4 * S)
            .polyline(&wiggle, S)
            .hover(CENTRE, 4 * S);
        let out = run(&mut rgb(), &sc.samples);
        assert_eq!(tokens(&out), vec![Token::Null, Token::Unknown, Token::Null]);
        assert!(matches!(
            out[1].cause,
            TokenCause::Rejected(Rejection::TooSmallSpan { .. })
        ));
    }

    #[test]
    fn malformed_samples_are_typed_errors_and_leave_the_state_alone() {
        let mut seg = rgb();
        let mut sc = Script::new(S);
        sc.hover(CENTRE, 5 * S);
        let mut out = Vec::new();
        for (k, s) in sc.samples.iter().enumerate() {
            out.extend(seg.push(*s).unwrap());
            if k == 10 {
                assert!(matches!(
                    seg.push(*s),
                    Err(SegmenterError::NonMonotonicStamp { .. })
                ));
                let bad = Sample::tracked(s.stamp_ns + 1, [f64::NAN, 1.0]);
                assert!(matches!(
                    seg.push(bad),
                    Err(SegmenterError::NonFinitePoint { .. })
                ));
            }
        }
        assert_eq!(tokens(&out), vec![Token::Null]);
        assert_eq!(out[0].stamp_ns, 4 * S);
        let bad = SegmenterConfig {
            anchor_radius_px: -1.0,
            ..SegmenterConfig::rgb()
        };
        assert!(matches!(
            Segmenter::new(bad),
            Err(SegmenterError::BadConfig { .. })
        ));
    }

    /// The window's first rest held `short_px` beside home (the rest after the acquisition
    /// sweep, whose arrival was lost), then START and Bit0 flown from home.
    fn start_from_a_short_first_rest(short_px: f64) -> Script {
        let mut sc = Script::new(0);
        sc.hover([CENTRE[0] + short_px, CENTRE[1]], 4 * S)
            .draw(Action::Start, CENTRE, 46.0, 4 * S)
            .hover(CENTRE, 4 * S)
            .draw(Action::Bit0, CENTRE, 46.0, 4 * S)
            .hover(CENTRE, 4 * S);
        sc
    }

    #[test]
    fn a_start_read_before_there_is_a_home_is_read_late_and_its_null_is_not() {
        // Without the second reading of a rest left by a jump, so that only the home reads it.
        let events = |reach_px| {
            Segmenter::new(SegmenterConfig {
                held_rests: false,
                pooled_home_px: reach_px,
                ..SegmenterConfig::events()
            })
            .unwrap()
        };
        let samples = start_from_a_short_first_rest(30.0).samples;
        let unpooled = run(&mut events(None), &samples);
        let (null, start, bit0) = (Token::Null, Token::Start, Token::Bit0);
        assert_eq!(tokens(&unpooled), [null, Token::Unknown, null, bit0, null]);
        assert!(matches!(
            unpooled[1].cause,
            TokenCause::Rejected(Rejection::NotClosed { .. })
        ));
        // With a pooled home START's NULL is emitted at once; START waits for the Bit0's rest
        // (the window's third), is read at the home it pools and emitted then, late, with its
        // own stamp.
        let reach = SegmenterConfig::events().pooled_home_px;
        let mut seg = events(reach);
        let mut emitted = Vec::new();
        for (k, &s) in samples.iter().enumerate() {
            emitted.extend(seg.push(s).unwrap().into_iter().map(|t| (k, t)));
        }
        let pooled: Vec<SegmentToken> = emitted.iter().map(|&(_, t)| t).collect();
        assert_eq!(tokens(&pooled), [null, null, start, bit0, null]);
        assert_eq!(emitted[1].1.stamp_ns, unpooled[2].stamp_ns, "NULL at once");
        assert_eq!(emitted[2].1.stamp_ns, unpooled[1].stamp_ns);
        let late: Vec<bool> = pooled.iter().map(|t| t.late).collect();
        assert_eq!(late, [false, false, true, false, false]);
        assert_eq!(emitted[2].0, emitted[4].0, "read with the Bit0's rest");
        // The decoder's parser puts START back where it belongs.
        let mut parser = crate::FrameParser::new();
        for t in &pooled {
            parser.push_segment(t);
        }
        assert_eq!(
            parser.held_tokens().collect::<Vec<_>>(),
            [null, start, null, bit0, null]
        );
        // A first rest beyond the reach stays a rejection, emitted late as well.
        let far = run(
            &mut events(reach),
            &start_from_a_short_first_rest(60.0).samples,
        );
        assert_eq!(tokens(&far), [null, null, Token::Unknown, bit0, null]);
        // Cut before the next rest: the NULL is out, START is dropped with the interruption.
        let mut cut = start_from_a_short_first_rest(30.0);
        cut.samples
            .truncate(samples.len() - 1 - (8 * S / PERIOD_NS) as usize);
        cut.sample(Sample::lost);
        let got = tokens(&run(&mut events(reach), &cut.samples));
        assert_eq!(got, [null, null, Token::Unknown], "{got:?}");
        // The first rest vetoed by a closed gate (opened 1.5 s into START's rest, when the
        // receiver's acquisition sees START's path settle) is a rest of the target once its
        // late NULL is emitted, and votes for the home as well: without it only two rests would
        // have been pooled when the Bit0 came to rest.
        let sc = start_from_a_short_first_rest(30.0);
        let got = tokens(&run(&mut events(reach), &gated(&sc, 8 * S + 3 * S / 2)));
        assert_eq!(got, [null, null, start, bit0, null]);
    }
}
