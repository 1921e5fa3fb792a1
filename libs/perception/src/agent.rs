//! The observer's recruitment logic above perception: reception windows and round resets from
//! the session, released frames → offers → the round's offer cache → the local allocation
//! decision. Pure: the caller feeds it what its own receiver decoded and the session controls.

use proto::allocation::{CachedOffer, OfferCache, Roster};
use proto::keys::ObserverId;
use proto::observer::Decision;
use proto::payload::Offer;
use proto::provenance::decide;
use proto::sched::SessionEvent;
use proto::{PayloadError, ReleasedFrame};

/// What the agent did with one released frame.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FrameOutcome {
    /// Stored as the round's offer for its site.
    Cached(Offer),
    /// A structurally valid frame whose payload is not a valid offer (site 0 or 3).
    Rejected(PayloadError),
}

/// A released frame with the agent's sequence number for it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AgentFrame {
    pub seq: u64,
    pub round: u32,
    pub frame: ReleasedFrame,
    pub outcome: FrameOutcome,
}

/// One observer's offer cache and allocation across rounds.
#[derive(Debug, Clone)]
pub struct ObserverAgent {
    id: ObserverId,
    roster: Roster,
    cache: OfferCache,
    receiving: bool,
    decided: bool,
    next_frame_seq: u64,
}

impl ObserverAgent {
    /// An agent for `id` with the shared roster (homes of every observer). Not receiving until
    /// the session opens a window.
    pub fn new(id: ObserverId, roster: Roster) -> Self {
        Self {
            id,
            roster,
            cache: OfferCache::new(0),
            receiving: false,
            decided: false,
            next_frame_seq: 0,
        }
    }

    pub fn id(&self) -> &ObserverId {
        &self.id
    }

    /// True while a reception window is open: only then is perception fed.
    pub fn receiving(&self) -> bool {
        self.receiving
    }

    /// The current round.
    pub fn round(&self) -> u32 {
        self.cache.round()
    }

    /// Applies a session control. Returns true when the caller must reset its receiver (a new
    /// round clears the frame parser and perception state along with the offer cache).
    pub fn on_session(&mut self, event: SessionEvent) -> bool {
        match event {
            SessionEvent::RoundReset { round } => {
                self.cache.start_round(round);
                self.decided = false;
                self.receiving = false;
                true
            }
            SessionEvent::WindowOpen { round } if round == self.cache.round() => {
                self.receiving = true;
                false
            }
            SessionEvent::WindowClose { .. } | SessionEvent::MissionEnd => {
                self.receiving = false;
                false
            }
            SessionEvent::WindowOpen { .. } => false,
        }
    }

    /// Takes the frames the receiver released at `now_ns`; returns them numbered with their
    /// outcome, and this round's decision if the cache became complete.
    pub fn on_frames(
        &mut self,
        frames: &[ReleasedFrame],
        now_ns: u64,
    ) -> (Vec<AgentFrame>, Option<Decision>) {
        let mut out = Vec::with_capacity(frames.len());
        for frame in frames {
            let seq = self.next_frame_seq;
            self.next_frame_seq += 1;
            let outcome = match Offer::from_payload(frame.payload) {
                Ok(offer) => {
                    self.cache.insert(CachedOffer {
                        offer,
                        frame_seq: seq,
                        final_null_ns: frame.final_null_ns(),
                    });
                    FrameOutcome::Cached(offer)
                }
                Err(e) => FrameOutcome::Rejected(e),
            };
            out.push(AgentFrame {
                seq,
                round: self.cache.round(),
                frame: frame.clone(),
                outcome,
            });
        }
        let decision = if self.decided {
            None
        } else {
            decide(&self.id, &self.cache, &self.roster, now_ns)
        };
        if decision.is_some() {
            self.decided = true;
        }
        (out, decision)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::Site;

    fn frame(bits: &str, final_null_ns: u64) -> ReleasedFrame {
        ReleasedFrame {
            payload: u8::from_str_radix(bits, 2).unwrap(),
            token_stamps_ns: (0..17)
                .map(|k| final_null_ns - (16 - k) * 1_000_000_000)
                .collect(),
        }
    }

    fn agent(name: &str) -> ObserverAgent {
        ObserverAgent::new(ObserverId::new(name).unwrap(), Roster::default_scene(3))
    }

    #[test]
    fn decides_once_both_sites_are_held_and_only_once_per_round() {
        let mut a = agent("O3");
        a.on_session(SessionEvent::RoundReset { round: 1 });
        a.on_session(SessionEvent::WindowOpen { round: 1 });
        assert!(a.receiving());
        let (f, d) = a.on_frames(&[frame("011010", 100_000_000_000)], 100_000_000_000);
        assert_eq!(
            f[0].outcome,
            FrameOutcome::Cached(Offer::new(Site::A, 2, 2).unwrap())
        );
        assert!(d.is_none(), "decided with only A");
        let (_, d) = a.on_frames(&[frame("100111", 200_000_000_000)], 200_040_000_000);
        let d = d.expect("decision with A and B");
        assert_eq!(d.assignment, Some(Site::B));
        assert_eq!(d.round, 1);
        assert_eq!(d.decided_ns, 200_040_000_000);
        assert_eq!(d.sources.len(), 2);
        let (_, again) = a.on_frames(&[frame("100111", 300_000_000_000)], 300_000_000_000);
        assert!(again.is_none(), "second decision in one round");
        // A new round forgets the cache: a single offer is not enough again.
        assert!(a.on_session(SessionEvent::RoundReset { round: 2 }));
        assert!(
            !a.receiving(),
            "round reset closes reception until the window opens"
        );
        a.on_session(SessionEvent::WindowOpen { round: 2 });
        let (_, d) = a.on_frames(&[frame("010000", 400_000_000_000)], 400_000_000_000);
        assert!(d.is_none());
        let (_, d) = a.on_frames(&[frame("100111", 500_000_000_000)], 500_000_000_000);
        assert_eq!(d.unwrap().assignment, Some(Site::B));
    }

    #[test]
    fn invalid_site_frames_are_rejected_not_cached() {
        let mut a = agent("O1");
        a.on_session(SessionEvent::RoundReset { round: 1 });
        let (f, d) = a.on_frames(
            &[
                frame("111010", 30_000_000_000),
                frame("000111", 40_000_000_000),
            ],
            40_000_000_000,
        );
        assert!(matches!(f[0].outcome, FrameOutcome::Rejected(_)));
        assert!(matches!(f[1].outcome, FrameOutcome::Rejected(_)));
        assert_eq!((f[0].seq, f[1].seq), (0, 1));
        assert!(d.is_none());
    }

    #[test]
    fn window_open_for_another_round_is_ignored() {
        let mut a = agent("O2");
        a.on_session(SessionEvent::RoundReset { round: 2 });
        a.on_session(SessionEvent::WindowOpen { round: 1 });
        assert!(!a.receiving());
        a.on_session(SessionEvent::WindowOpen { round: 2 });
        assert!(a.receiving());
        a.on_session(SessionEvent::WindowClose { round: 2 });
        assert!(!a.receiving());
    }
}
