//! `session.json`: what the launcher saw of a session beyond the observers' own streams — the
//! performer's flown symbols (`truth/performer`), the session controls (`sched/session`), each
//! observer's trips and site stays (from `sim/state`) and the scheduler's report. The report's
//! timeline and timing tables are drawn from it.

use std::collections::BTreeMap;

use proto::scene::distance_m;
use proto::{
    MissionReport, PerformerActivity, PerformerTruth, SessionEvent, SessionTick, SimState, Site,
};
use serde::{Deserialize, Serialize};

/// Distance from home beyond which an observer counts as away, m (the launcher's home check).
pub const AWAY_M: f64 = 0.05;
/// Distance from a site within which an observer counts as at the site, m.
pub const AT_SITE_M: f64 = 0.05;

/// One contiguous stretch of the performer doing one thing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PerformerSpan {
    pub start_ns: u64,
    /// Exclusive end (the stamp of the first truth sample of the next span).
    pub end_ns: u64,
    pub round: u32,
    pub activity: PerformerActivity,
    /// The offer's six bits while inside a frame.
    pub offer_bits: Option<String>,
    /// Position 0–16 in the frame.
    pub frame_slot: Option<u8>,
}

/// A session control as it happened.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ControlRecord {
    pub stamp_ns: u64,
    pub event: SessionEvent,
}

/// One stay of an observer within [`AT_SITE_M`] of a site.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SiteStay {
    pub observer: String,
    pub site: Site,
    pub arrive_ns: u64,
    pub leave_ns: Option<u64>,
}

/// One trip of an observer beyond [`AWAY_M`] of its home.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TripRecord {
    pub observer: String,
    pub leave_ns: u64,
    pub back_ns: Option<u64>,
}

/// Everything in `session.json`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SessionRecord {
    pub performer: Vec<PerformerSpan>,
    pub controls: Vec<ControlRecord>,
    pub trips: Vec<TripRecord>,
    pub stays: Vec<SiteStay>,
    pub report: Option<MissionReport>,
}

/// Builds a [`SessionRecord`] from bus messages as they arrive.
#[derive(Debug, Default)]
pub struct SessionRecorder {
    record: SessionRecord,
    homes_m: BTreeMap<String, [f64; 3]>,
    last_truth_ns: Option<u64>,
    last_state_ns: Option<u64>,
}

impl SessionRecorder {
    pub fn new(homes_m: BTreeMap<String, [f64; 3]>) -> Self {
        Self {
            homes_m,
            ..Self::default()
        }
    }

    pub fn truth(&mut self, t: &PerformerTruth) {
        if self.last_truth_ns.is_some_and(|l| t.stamp_ns <= l) {
            return;
        }
        self.last_truth_ns = Some(t.stamp_ns);
        let offer_bits = t.offer.map(|o| o.to_bits());
        if let Some(last) = self.record.performer.last_mut() {
            last.end_ns = t.stamp_ns;
            if last.activity == t.activity
                && last.round == t.round
                && last.offer_bits == offer_bits
                && last.frame_slot == t.frame_slot
            {
                return;
            }
        }
        self.record.performer.push(PerformerSpan {
            start_ns: t.stamp_ns,
            end_ns: t.stamp_ns,
            round: t.round,
            activity: t.activity,
            offer_bits,
            frame_slot: t.frame_slot,
        });
    }

    pub fn session(&mut self, s: &SessionTick) {
        self.record
            .controls
            .extend(s.controls.iter().map(|c| ControlRecord {
                stamp_ns: c.stamp_ns,
                event: c.event,
            }));
    }

    pub fn state(&mut self, s: &SimState) {
        if self.last_state_ns.is_some_and(|l| s.stamp_ns <= l) {
            return;
        }
        self.last_state_ns = Some(s.stamp_ns);
        for d in &s.drones {
            let Some(home) = self.homes_m.get(&d.name) else {
                continue;
            };
            let away = distance_m(d.pos_m, *home) > AWAY_M;
            let open_trip = self
                .record
                .trips
                .iter_mut()
                .rev()
                .find(|t| t.observer == d.name)
                .filter(|t| t.back_ns.is_none());
            match (away, open_trip) {
                (true, None) => self.record.trips.push(TripRecord {
                    observer: d.name.clone(),
                    leave_ns: s.stamp_ns,
                    back_ns: None,
                }),
                (false, Some(t)) => t.back_ns = Some(s.stamp_ns),
                _ => {}
            }
            let here = Site::ALL
                .into_iter()
                .find(|site| distance_m(d.pos_m, site.position_m()) <= AT_SITE_M);
            let open_stay = self
                .record
                .stays
                .iter_mut()
                .rev()
                .find(|st| st.observer == d.name)
                .filter(|st| st.leave_ns.is_none());
            match (here, open_stay) {
                (Some(site), None) => self.record.stays.push(SiteStay {
                    observer: d.name.clone(),
                    site,
                    arrive_ns: s.stamp_ns,
                    leave_ns: None,
                }),
                (None, Some(st)) => st.leave_ns = Some(s.stamp_ns),
                _ => {}
            }
        }
    }

    pub fn report(&mut self, r: &MissionReport) {
        self.record.report = Some(r.clone());
    }

    /// The record; the last performer span ends at `end_ns`.
    pub fn finish(mut self, end_ns: u64) -> SessionRecord {
        if let Some(last) = self.record.performer.last_mut() {
            last.end_ns = last.end_ns.max(end_ns);
        }
        self.record
    }
}

impl SessionRecord {
    /// Start of each offer's frame (its slot-0 NULL) by (round, site): the paper's "offer
    /// start". The first flight of an offer in a round counts.
    pub fn offer_starts_ns(&self) -> BTreeMap<(u32, Site), u64> {
        let mut out = BTreeMap::new();
        for sp in &self.performer {
            if sp.frame_slot != Some(0) {
                continue;
            }
            let Some(site) = sp
                .offer_bits
                .as_deref()
                .and_then(|b| u8::from_str_radix(b, 2).ok())
                .and_then(|p| proto::Offer::from_payload(p).ok())
                .map(|o| o.site)
            else {
                continue;
            };
            out.entry((sp.round, site)).or_insert(sp.start_ns);
        }
        out
    }

    /// Start of the first offer's frame, if any offer was flown.
    pub fn first_offer_start_ns(&self) -> Option<u64> {
        self.performer
            .iter()
            .find(|sp| sp.offer_bits.is_some())
            .map(|sp| sp.start_ns)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::{Action, DronePose, Offer, SessionControl, TICK_NS};

    fn truth(tick: u64, activity: PerformerActivity, slot: Option<u8>) -> PerformerTruth {
        PerformerTruth {
            tick,
            stamp_ns: tick * TICK_NS,
            round: 1,
            activity,
            offer: slot.map(|_| Offer::new(Site::B, 1, 3).unwrap()),
            frame_slot: slot,
        }
    }

    fn state(tick: u64, x_m: f64) -> SimState {
        SimState {
            tick,
            stamp_ns: tick * TICK_NS,
            drones: vec![DronePose {
                name: "O1".into(),
                pos_m: [x_m, -1.65, 1.3],
                quat_wxyz: [1.0, 0.0, 0.0, 0.0],
                vel_mps: [0.0; 3],
                ang_vel_radps: [0.0; 3],
            }],
        }
    }

    #[test]
    fn spans_trips_and_stays_are_built_from_the_streams() {
        let mut r = SessionRecorder::new([("O1".to_string(), [0.0, -1.65, 1.3])].into());
        r.truth(&truth(1, PerformerActivity::Idle, None));
        r.truth(&truth(2, PerformerActivity::Idle, None));
        r.truth(&truth(3, PerformerActivity::NullHover, Some(0)));
        r.truth(&truth(5, PerformerActivity::Action(Action::Start), Some(1)));
        r.truth(&truth(5, PerformerActivity::Idle, None)); // a duplicate stamp is ignored
        r.session(&SessionTick {
            tick: 4,
            controls: vec![SessionControl {
                tick: 4,
                stamp_ns: 4 * TICK_NS,
                event: SessionEvent::WindowOpen { round: 1 },
            }],
        });
        for (tick, x) in [
            (1, 0.0),
            (2, 0.5),
            (3, 1.65),
            (4, 1.66),
            (5, 1.0),
            (6, 0.01),
        ] {
            r.state(&state(tick, x));
        }
        let rec = r.finish(7 * TICK_NS);
        let acts: Vec<_> = rec
            .performer
            .iter()
            .map(|s| (s.activity, s.start_ns / TICK_NS, s.end_ns / TICK_NS))
            .collect();
        assert_eq!(
            acts,
            [
                (PerformerActivity::Idle, 1, 3),
                (PerformerActivity::NullHover, 3, 5),
                (PerformerActivity::Action(Action::Start), 5, 7)
            ]
        );
        assert_eq!(rec.first_offer_start_ns(), Some(3 * TICK_NS));
        assert_eq!(rec.offer_starts_ns(), [((1, Site::B), 3 * TICK_NS)].into());
        assert_eq!(
            rec.trips,
            [TripRecord {
                observer: "O1".into(),
                leave_ns: 2 * TICK_NS,
                back_ns: Some(6 * TICK_NS)
            }]
        );
        assert_eq!(
            rec.stays,
            [SiteStay {
                observer: "O1".into(),
                site: Site::B,
                arrive_ns: 3 * TICK_NS,
                leave_ns: Some(5 * TICK_NS)
            }]
        );
        assert_eq!(rec.controls.len(), 1);
    }
}
