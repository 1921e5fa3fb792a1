//! One observer, exactly as every caller runs it: the tick assembler ([`crate::tick`]) decides
//! which tick is next and with what, the runtime ([`crate::runtime`]) applies the session and
//! runs perception and the agent. `observer-node`, `waggle replay` and the in-process mission
//! (`waggle mission`, trials, studies) all drive this one type, so a change to observer
//! behaviour is made here once and every one of them sees it.
//!
//! Feed it what arrived ([`ObserverCore::clock`], [`ObserverCore::session`],
//! [`ObserverCore::packet`]); pull processed ticks with [`ObserverCore::next`] until it returns
//! `None`, then [`ObserverCore::ended`] says whether the session ended the mission or more
//! input is needed.

use crate::runtime::{ObserverRuntime, TickReport};
use crate::sensing::PerceptionError;
use crate::tick::{MissingReason, SensorPacket, Step, TickAssembler, TickInput, Waiting};
use std::collections::BTreeMap;

use proto::{EgoRotation, ObserverId, SessionControl};

/// One processed tick: what it was processed with and what the observer publishes for it.
#[derive(Debug, Clone, PartialEq)]
pub struct Processed {
    pub tick: u64,
    pub input: TickInput,
    pub report: TickReport,
}

/// An observer's assembler and runtime, driven as one.
#[derive(Debug)]
pub struct ObserverCore {
    runtime: ObserverRuntime,
    assembler: TickAssembler,
    /// The airframe's turn from home when each tick's packet was made, until that tick is
    /// processed ([`ObserverCore::attitude`]).
    attitudes: BTreeMap<u64, Option<EgoRotation>>,
    /// The turn perception undoes now.
    ego: Option<EgoRotation>,
}

impl ObserverCore {
    pub fn new(runtime: ObserverRuntime) -> Self {
        Self {
            runtime,
            assembler: TickAssembler::new(),
            attitudes: BTreeMap::new(),
            ego: None,
        }
    }

    pub fn id(&self) -> &ObserverId {
        self.runtime.id()
    }

    /// True once the session's `MissionEnd` was applied: nothing more is processed.
    pub fn ended(&self) -> bool {
        self.runtime.ended()
    }

    /// Why the receiving chain stopped working, once it has (a plug-in's failure).
    pub fn receiver_failure(&self) -> Option<String> {
        self.runtime.receiver_failure()
    }

    /// The next tick to process.
    pub fn next_tick(&self) -> u64 {
        self.assembler.next_tick()
    }

    /// What the assembler waits for before it can go on.
    pub fn waiting(&self) -> Waiting {
        self.assembler.waiting()
    }

    /// `clock{tick}` arrived.
    pub fn clock(&mut self, tick: u64) {
        self.assembler.clock(tick);
    }

    /// Every clock up to `tick` is known (a recording's watermark, the in-process lockstep).
    pub fn clocks_through(&mut self, tick: u64) {
        self.assembler.clocks_through(tick);
    }

    /// The session controls of tick `tick`.
    pub fn session(&mut self, tick: u64, controls: Vec<SessionControl>) {
        self.assembler.session(tick, controls);
    }

    /// The camera's notice that it dropped its packet of `tick`.
    pub fn dropped(&mut self, tick: u64) {
        self.assembler.dropped(tick);
    }

    /// One packet of this observer's own sensor: its tick, and false when that tick was
    /// already processed (stale, dropped).
    pub fn packet(&mut self, packet: impl Into<SensorPacket>) -> (u64, bool) {
        self.assembler.packet(packet)
    }

    /// The observer's airframe had turned by `ego` from its home attitude when the packet of
    /// `tick` was made (its attitude estimate): perception undoes that turn on the tick's
    /// packet and keeps it until told another. Ticks without one keep the last.
    pub fn attitude(&mut self, tick: u64, ego: Option<EgoRotation>) {
        if tick >= self.assembler.next_tick() {
            self.attitudes.insert(tick, ego);
        }
    }

    /// The turn from home perception undoes now (`None`: none, or never told).
    pub fn ego_rotation(&self) -> Option<EgoRotation> {
        self.ego
    }

    /// Processes up to the next tick that what has arrived allows, applying the session controls
    /// on the way; `None` when it must wait for more input or the mission ended. `judge` decides
    /// whether a packet that has not arrived (and no later one has) is missing.
    pub fn next(
        &mut self,
        mut judge: impl FnMut(u64) -> Option<MissingReason>,
    ) -> Result<Option<Processed>, PerceptionError> {
        while !self.runtime.ended() {
            match self.assembler.next_step(&mut judge) {
                None => return Ok(None),
                Some(Step::Session { controls, .. }) => self.runtime.apply_session(&controls),
                Some(Step::Tick { tick, input }) => {
                    let later = self.attitudes.split_off(&tick);
                    // Only older ticks' turns were told: the latest of them holds.
                    let older = self.attitudes.values().next_back().copied();
                    self.attitudes = later;
                    if let Some(ego) = self.attitudes.remove(&tick).or(older) {
                        self.ego = ego;
                        self.runtime.set_ego_rotation(ego);
                    }
                    let report = self.runtime.step(tick, input.data())?;
                    return Ok(Some(Processed {
                        tick,
                        input,
                        report,
                    }));
                }
            }
        }
        Ok(None)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::{EventPacket, Modality, Roster, SessionEvent, TICK_NS};

    fn core() -> ObserverCore {
        ObserverCore::new(
            ObserverRuntime::new(
                ObserverId::new("O2").unwrap(),
                Roster::default_scene(3),
                Modality::Events,
            )
            .unwrap(),
        )
    }

    fn packet(tick: u64) -> EventPacket {
        EventPacket::from_events(
            tick - 1,
            ((tick - 1) * TICK_NS, tick * TICK_NS),
            (proto::scene::IMAGE_WIDTH_PX, proto::scene::IMAGE_HEIGHT_PX),
            &[],
        )
    }

    fn control(tick: u64, event: SessionEvent) -> Vec<SessionControl> {
        vec![SessionControl {
            tick,
            stamp_ns: tick * TICK_NS,
            event,
        }]
    }

    #[test]
    fn ticks_come_out_in_order_and_the_session_ends_it() {
        let mut c = core();
        let never = |_| None;
        assert_eq!(c.next(never).unwrap(), None, "no clock yet");
        assert!(!c.ended());
        c.clocks_through(2);
        c.session(0, control(0, SessionEvent::RoundReset { round: 1 }));
        c.packet(packet(2));
        c.packet(packet(1));
        let ticks: Vec<u64> = std::iter::from_fn(|| c.next(never).unwrap())
            .map(|p| p.tick)
            .collect();
        assert_eq!(ticks, [0, 1], "tick 2 waits for the session of tick 1");
        assert_eq!(c.waiting(), Waiting::Session(1));
        c.session(1, control(1, SessionEvent::MissionEnd));
        assert_eq!(c.next(never).unwrap(), None);
        assert!(c.ended(), "the end is applied before tick 2");
        assert_eq!(c.next_tick(), 2);
    }

    #[test]
    fn the_judge_is_asked_for_a_packet_that_never_came() {
        let mut c = core();
        c.clocks_through(1);
        c.session(0, Vec::new());
        let p = c.next(|_| None).unwrap().unwrap();
        assert_eq!(p.tick, 0);
        assert_eq!(c.next(|_| None).unwrap(), None);
        let p = c.next(|_| Some(MissingReason::Lost)).unwrap().unwrap();
        assert_eq!((p.tick, p.input.missing()), (1, Some(MissingReason::Lost)));
        assert_eq!(p.report.status.input, proto::InputState::Missing);
    }

    #[test]
    fn each_tick_is_processed_with_the_turn_its_packet_was_made_with() {
        let turn = |deg: f64| {
            let h = deg.to_radians() / 2.0;
            EgoRotation::between([1.0, 0.0, 0.0, 0.0], [h.cos(), h.sin(), 0.0, 0.0])
        };
        let mut c = core();
        c.clocks_through(4);
        for t in 0..5 {
            c.session(t, Vec::new());
        }
        for t in 1..=4 {
            c.packet(packet(t));
        }
        c.attitude(1, turn(2.0));
        c.attitude(3, turn(-1.0));
        c.attitude(4, None);
        let mut seen = Vec::new();
        while let Some(p) = c.next(|_| None).unwrap() {
            seen.push((p.tick, c.ego_rotation()));
        }
        assert_eq!(
            seen,
            [
                (0, None),
                (1, turn(2.0)),
                // Tick 2 was told nothing: the turn of tick 1 holds.
                (2, turn(2.0)),
                (3, turn(-1.0)),
                (4, None),
            ]
        );
        // A turn told for a tick already processed changes nothing.
        c.attitude(2, turn(5.0));
        assert_eq!(c.ego_rotation(), None);
    }
}
