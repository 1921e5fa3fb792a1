//! Acquisition and the tracking lease: when may an event receiver confirm NULL at all?
//!
//! Silence proves nothing about a target the receiver has never seen, so the NULL gate opens only
//! after the receiver has **observed a closed moving path**: the tracked point left a place,
//! moved at least [`AcquisitionConfig::min_span_px`], and came back to rest within
//! [`AcquisitionConfig::closure_limit`] of its span from where it started (the performer's
//! left–right acquisition sweep is one; so is every frame symbol, so a receiver that missed the
//! sweep re-acquires on the next symbol). The receiver is not told which motion is which, nor
//! when it happens.
//!
//! A rest "settles" after [`AcquisitionConfig::settle_ns`] within
//! [`AcquisitionConfig::rest_radius_px`] of its first point. Settling is when closure is
//! judged: the turnarounds inside a symbol dwell for less, so they do not split its path. A path
//! may start at the first localisation or at any earlier settled rest.
//!
//! Once acquired, the gate stays open while the age of the last **event-supported** estimate is
//! at most [`AcquisitionConfig::lease_ns`]. When the lease runs out the acquisition is dropped:
//! quiet cannot renew it, and neither can an open motion — only a new closed path.
//!
//! Points are in whatever image the receiver hands over; the event receiver hands over the
//! track as its unturned camera would have seen it (`proto::stabilise`), the image the
//! segmenter reads symbols in, so a leaning observer's sweep still closes and its rests stay put.

use proto::MatchSettings;

use crate::events::error::EventReceiverError;

/// Acquisition settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AcquisitionConfig {
    /// A rest holds while the point stays this close to the rest's first point (NULL anchor
    /// radius).
    pub rest_radius_px: f64,
    /// A rest this long is where a moving path ends.
    pub settle_ns: u64,
    /// Longest age of the last event-supported estimate for which NULL may be confirmed.
    pub lease_ns: u64,
    /// Fewest samples of a closed path.
    pub min_points: usize,
    /// Smallest largest-coordinate span of a closed path, pixels.
    pub min_span_px: f64,
    /// Largest end-to-start distance of a closed path, as a share of its span.
    pub closure_limit: f64,
    /// Path samples kept while no closed path is found (older ones are dropped in halves).
    pub max_path_points: usize,
}

impl AcquisitionConfig {
    /// Paper settings: 20 px anchor radius, 20 s lease, path support and closure of the event
    /// matcher ([`MatchSettings::events`]). The 1.5 s settle is longer than a symbol's
    /// turnaround dwell (≈ 1 s within 20 px at the paper's stroke timing) and leaves 1.5 s of a
    /// 3 s NULL confirmation after it.
    pub fn paper() -> Self {
        let m = MatchSettings::events();
        Self {
            rest_radius_px: 20.0,
            settle_ns: 1_500_000_000,
            lease_ns: 20_000_000_000,
            min_points: m.min_points,
            min_span_px: m.min_span_px,
            closure_limit: m.closure_limit,
            max_path_points: 3_000,
        }
    }

    /// Rejects settings no receiver could run with.
    pub fn validate(&self) -> Result<(), EventReceiverError> {
        let bad = |setting: &'static str, reason: String| {
            Err(EventReceiverError::BadSetting { setting, reason })
        };
        if !(self.rest_radius_px.is_finite() && self.rest_radius_px > 0.0) {
            return bad(
                "rest_radius_px",
                format!("{} is not a positive distance", self.rest_radius_px),
            );
        }
        if !(self.min_span_px.is_finite() && self.min_span_px > 0.0) {
            return bad(
                "min_span_px",
                format!("{} is not a positive distance", self.min_span_px),
            );
        }
        if !(self.closure_limit.is_finite() && self.closure_limit >= 0.0) {
            return bad(
                "closure_limit",
                format!("{} is not a share", self.closure_limit),
            );
        }
        if self.settle_ns == 0 || self.lease_ns == 0 {
            return bad("settle_ns / lease_ns", "must be positive".into());
        }
        if self.max_path_points < 2 * self.min_points.max(1) {
            return bad(
                "max_path_points",
                format!("{} cannot hold a closed path", self.max_path_points),
            );
        }
        Ok(())
    }
}

impl Default for AcquisitionConfig {
    fn default() -> Self {
        Self::paper()
    }
}

/// A change of the acquisition state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AcquisitionEvent {
    /// A closed path ended in a settled rest at `stamp_ns`.
    Acquired {
        stamp_ns: u64,
        span_px: f64,
        closure: f64,
        points: usize,
    },
    /// The lease ran out at `stamp_ns`: no NULL until the next closed path.
    LeaseExpired {
        stamp_ns: u64,
        last_supported_ns: u64,
    },
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Rest {
    anchor_px: [f64; 2],
    since_ns: u64,
    /// Index of the anchor in `path_px`.
    anchor_index: usize,
    settled: bool,
}

/// Acquisition state of one receiver.
#[derive(Debug, Clone)]
pub struct Acquisition {
    config: AcquisitionConfig,
    path_px: Vec<[f64; 2]>,
    /// Indices into `path_px` where a closed path may start: the first localisation and every
    /// settled rest since.
    origins: Vec<usize>,
    rest: Option<Rest>,
    acquired_ns: Option<u64>,
    last_supported_ns: Option<u64>,
}

impl Acquisition {
    pub fn new(config: AcquisitionConfig) -> Result<Self, EventReceiverError> {
        config.validate()?;
        Ok(Self {
            config,
            path_px: Vec::new(),
            origins: Vec::new(),
            rest: None,
            acquired_ns: None,
            last_supported_ns: None,
        })
    }

    pub fn config(&self) -> &AcquisitionConfig {
        &self.config
    }

    /// Stamp of the closed path that opened the current acquisition.
    pub fn acquired_ns(&self) -> Option<u64> {
        self.acquired_ns
    }

    pub fn is_acquired(&self) -> bool {
        self.acquired_ns.is_some()
    }

    /// Stamp of the last event-supported estimate since the last revocation.
    pub fn last_supported_ns(&self) -> Option<u64> {
        self.last_supported_ns
    }

    /// The receiver's NULL gate at `stamp_ns` (call after [`Acquisition::observe`] for it).
    pub fn null_allowed(&self, stamp_ns: u64) -> bool {
        self.acquired_ns.is_some()
            && self
                .last_supported_ns
                .is_some_and(|s| stamp_ns.saturating_sub(s) <= self.config.lease_ns)
    }

    /// Forgets the target: path, rest, acquisition and lease (an interruption or a reset).
    pub fn revoke(&mut self) {
        self.path_px.clear();
        self.origins.clear();
        self.rest = None;
        self.acquired_ns = None;
        self.last_supported_ns = None;
    }

    /// Takes the tracker's estimate at `stamp_ns`; `supported` when this packet's own events
    /// localised it (not a held estimate).
    pub fn observe(
        &mut self,
        stamp_ns: u64,
        point_px: [f64; 2],
        supported: bool,
    ) -> Option<AcquisitionEvent> {
        if supported {
            self.last_supported_ns = Some(stamp_ns);
        }
        let mut event = None;
        if self.acquired_ns.is_some()
            && let Some(last) = self.last_supported_ns
            && stamp_ns.saturating_sub(last) > self.config.lease_ns
        {
            self.acquired_ns = None;
            event = Some(AcquisitionEvent::LeaseExpired {
                stamp_ns,
                last_supported_ns: last,
            });
        }
        if self.path_px.len() >= self.config.max_path_points {
            self.drop_oldest_half();
        }
        let index = self.path_px.len();
        if index == 0 {
            self.origins.push(0);
        }
        self.path_px.push(point_px);
        let radius = self.config.rest_radius_px;
        let settle_ns = self.config.settle_ns;
        let settled_anchor = match self.rest.as_mut() {
            Some(rest) if dist(point_px, rest.anchor_px) <= radius => {
                let settles = !rest.settled && stamp_ns - rest.since_ns >= settle_ns;
                rest.settled |= settles;
                settles.then_some(rest.anchor_index)
            }
            _ => {
                self.rest = Some(Rest {
                    anchor_px: point_px,
                    since_ns: stamp_ns,
                    anchor_index: index,
                    settled: false,
                });
                None
            }
        };
        if let Some(anchor_index) = settled_anchor {
            if let Some((span_px, closure, points)) = self.closed_path(anchor_index) {
                self.acquired_ns = Some(stamp_ns);
                event = Some(AcquisitionEvent::Acquired {
                    stamp_ns,
                    span_px,
                    closure,
                    points,
                });
                // Later paths start from this rest.
                self.path_px.drain(..index);
                self.origins = vec![0];
                if let Some(rest) = self.rest.as_mut() {
                    rest.anchor_index = 0;
                }
            } else {
                // A settled rest is where a later closed path may start: at the point where
                // the target settled, not at the rest's anchor up to one radius short of it.
                self.origins.push(index);
            }
        }
        event
    }

    /// The best closed path ending at the current point and starting at an origin before the
    /// current rest's anchor (so that it contains motion): (span, closure, points).
    fn closed_path(&self, anchor_index: usize) -> Option<(f64, f64, usize)> {
        let end = *self.path_px.last()?;
        self.origins
            .iter()
            .filter(|&&o| o < anchor_index)
            .filter_map(|&o| {
                let path = &self.path_px[o..];
                let span_px = largest_span(path);
                let closure = dist(path[0], end) / span_px;
                (path.len() >= self.config.min_points
                    && span_px >= self.config.min_span_px
                    && closure <= self.config.closure_limit)
                    .then_some((span_px, closure, path.len()))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }

    fn drop_oldest_half(&mut self) {
        let cut = self.path_px.len() / 2;
        self.path_px.drain(..cut);
        self.origins.retain(|&o| o >= cut);
        for o in &mut self.origins {
            *o -= cut;
        }
        if let Some(rest) = self.rest.as_mut() {
            rest.anchor_index = rest.anchor_index.saturating_sub(cut);
        }
    }
}

fn largest_span(path: &[[f64; 2]]) -> f64 {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for p in path {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (hi[0] - lo[0]).max(hi[1] - lo[1])
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    const STEP: u64 = 40_000_000;

    /// Feeds `points` at 25 Hz from `t0`; returns the events and the next stamp.
    fn feed(
        a: &mut Acquisition,
        t0: u64,
        points: &[[f64; 2]],
        supported: bool,
    ) -> (Vec<AcquisitionEvent>, u64) {
        let mut events = Vec::new();
        let mut t = t0;
        for &p in points {
            events.extend(a.observe(t, p, supported));
            t += STEP;
        }
        (events, t)
    }

    fn line(from: [f64; 2], to: [f64; 2], n: usize) -> Vec<[f64; 2]> {
        (0..n)
            .map(|i| {
                let s = i as f64 / n as f64;
                [
                    from[0] + s * (to[0] - from[0]),
                    from[1] + s * (to[1] - from[1]),
                ]
            })
            .collect()
    }

    fn hold(p: [f64; 2], seconds: u64) -> Vec<[f64; 2]> {
        vec![p; (seconds * 25) as usize]
    }

    #[test]
    fn a_closed_sweep_ending_in_a_settled_rest_acquires() {
        let mut a = Acquisition::new(AcquisitionConfig::paper()).unwrap();
        let c = [320.0, 240.0];
        let mut sweep = line(c, [390.0, 240.0], 25);
        sweep.extend(line([390.0, 240.0], [250.0, 240.0], 50));
        sweep.extend(line([250.0, 240.0], c, 25));
        let (events, t) = feed(&mut a, 0, &sweep, true);
        assert!(
            events.is_empty() && !a.null_allowed(t),
            "not before the rest settles"
        );
        let (events, t) = feed(&mut a, t, &hold(c, 2), false);
        assert!(
            matches!(events[..], [AcquisitionEvent::Acquired { points, .. }] if points > 100),
            "{events:?}"
        );
        assert!(a.null_allowed(t));
    }

    #[test]
    fn silence_and_open_motion_do_not_acquire_but_turnaround_dwell_does_not_split_a_path() {
        let mut a = Acquisition::new(AcquisitionConfig::paper()).unwrap();
        // An open move to the right, then a long rest: nothing closed.
        let (events, t) = feed(&mut a, 0, &line([320.0, 240.0], [400.0, 240.0], 30), true);
        let (more, t) = feed(&mut a, t, &hold([400.0, 240.0], 5), false);
        assert!(events.is_empty() && more.is_empty() && !a.null_allowed(t));
        // Back with a 1 s pause at the far turnaround (shorter than the settle): the path from
        // the first localisation is closed when the final rest settles.
        let mut back = line([400.0, 240.0], [460.0, 240.0], 20);
        back.extend(hold([460.0, 240.0], 1));
        back.extend(line([460.0, 240.0], [400.0, 240.0], 20));
        let (events, t) = feed(&mut a, t, &back, true);
        assert!(events.is_empty());
        let (events, _) = feed(&mut a, t, &hold([402.0, 241.0], 2), false);
        assert!(
            matches!(events[..], [AcquisitionEvent::Acquired { .. }]),
            "{events:?}"
        );
    }

    #[test]
    fn lease_expires_twenty_seconds_after_the_last_supported_estimate() {
        let mut a = Acquisition::new(AcquisitionConfig::paper()).unwrap();
        let c = [320.0, 240.0];
        let mut sweep = line(c, [380.0, 240.0], 20);
        sweep.extend(line([380.0, 240.0], c, 20));
        let (_, t) = feed(&mut a, 0, &sweep, true);
        let last_supported = t - STEP;
        let (events, t) = feed(&mut a, t, &hold(c, 20), false);
        assert!(matches!(events[..], [AcquisitionEvent::Acquired { .. }]));
        assert!(
            a.null_allowed(t - STEP),
            "age {} ns",
            t - STEP - last_supported
        );
        let (events, t) = feed(&mut a, t, &hold(c, 1), false);
        assert!(
            matches!(events[..], [AcquisitionEvent::LeaseExpired { .. }]),
            "{events:?}"
        );
        assert!(!a.null_allowed(t));
        // An open motion renews support but not the acquisition.
        let (_, t) = feed(&mut a, t, &line(c, [380.0, 240.0], 20), true);
        let (events, t) = feed(&mut a, t, &hold([380.0, 240.0], 3), false);
        assert!(events.is_empty() && !a.null_allowed(t));
        // A closed one does.
        let mut vee = line([380.0, 240.0], [410.0, 280.0], 15);
        vee.extend(line([410.0, 280.0], [440.0, 240.0], 15));
        vee.extend(line([440.0, 240.0], [380.0, 240.0], 15));
        let (_, t) = feed(&mut a, t, &vee, true);
        let (events, t) = feed(&mut a, t, &hold([380.0, 240.0], 2), false);
        assert!(
            matches!(events[..], [AcquisitionEvent::Acquired { .. }]),
            "{events:?}"
        );
        assert!(a.null_allowed(t));
        a.revoke();
        assert!(!a.null_allowed(t) && !a.is_acquired());
    }

    #[test]
    fn long_wandering_keeps_bounded_memory() {
        let mut cfg = AcquisitionConfig::paper();
        cfg.max_path_points = 100;
        let mut a = Acquisition::new(cfg).unwrap();
        let wander: Vec<_> = (0..1000).map(|i| [f64::from(i) * 0.5, 240.0]).collect();
        feed(&mut a, 0, &wander, true);
        assert!(a.path_px.len() <= 100);
        assert!(a.origins.iter().all(|&o| o < a.path_px.len()));
    }
}
