//! One observer's tick, exactly as the observer process runs it: the scheduler's session
//! controls, this observer's own sensor input for the tick (or the knowledge that it is
//! missing), perception, the agent, and the messages to publish. Pure: the process shell feeds
//! it what arrived and publishes what it returns.
//!
//! Perception is fed only while a reception window is open (observers do not look while they
//! fly). A missing packet interrupts perception once per gap, when the gap starts inside a
//! window — silence must never confirm a NULL.

use proto::Rectification;
use proto::frame::FrameParser;
use proto::scene::{ObserverCamera, Placement};
use proto::{
    Decision, FrameEvent, InputState, ObserverId, ObserverPhase, ObserverStatus, ObserverTrack,
    Roster, SessionControl, SessionEvent, Site, TICK_NS, TokenEvent, TrackSample,
};

use crate::agent::ObserverAgent;
use crate::sensing::{Perception, PerceptionError, Receiving, SensorInput};
use proto::Modality;
use proto::decoder::DecodeStep;

/// What the observer has for one tick.
#[derive(Debug, Clone, Copy)]
pub enum TickData<'a> {
    /// Tick 0 covers no sensor interval: nothing is expected.
    Nothing,
    /// The tick's packet from this observer's own sensor.
    Packet(SensorInput<'a>),
    /// The packet was judged missing (later packet, dead camera, or grace period).
    Missing,
}

/// What the observer publishes after one tick.
#[derive(Debug, Clone, PartialEq)]
pub struct TickReport {
    pub tokens: Vec<TokenEvent>,
    pub frames: Vec<FrameEvent>,
    pub decision: Option<Decision>,
    pub status: ObserverStatus,
    /// Where perception placed the target this tick (only when it was fed a packet).
    pub track: Option<ObserverTrack>,
}

/// One observer's state across the mission.
#[derive(Debug)]
pub struct ObserverRuntime {
    id: ObserverId,
    agent: ObserverAgent,
    perception: Box<dyn Receiving>,
    /// Mirrors the decoder's frame parser (same tokens, same interruptions) for the status.
    parser: FrameParser,
    next_token_seq: u64,
    frames_released: u64,
    stream_broken: bool,
    assignment: Option<Option<Site>>,
    ended: bool,
}

impl ObserverRuntime {
    pub fn new(
        id: ObserverId,
        roster: Roster,
        modality: Modality,
    ) -> Result<Self, PerceptionError> {
        // The observer knows the map: its own home, hence its camera's pose.
        let perception = match Self::home_camera(&id, &roster) {
            Some(camera) => Perception::for_camera(modality, camera, Rectification::default())?,
            None => Perception::new(modality)?,
        };
        Ok(Self::with_perception(id, roster, perception))
    }

    /// The camera of observer `id` at its home on `roster`'s map (`None`: not on the roster).
    pub fn home_camera(id: &ObserverId, roster: &Roster) -> Option<ObserverCamera> {
        roster
            .entries()
            .iter()
            .find(|e| e.observer == *id)
            .map(|e| Placement::aimed_from(e.home_m).camera())
    }

    /// An observer whose receiving chain is `perception` (e.g. the ideal baseline's
    /// [`Perception::tracked`]).
    pub fn with_perception(id: ObserverId, roster: Roster, perception: Perception) -> Self {
        Self::with_receiver(id, roster, Box::new(perception))
    }

    /// An observer whose receiving chain lives elsewhere (a plug-in, `receiver-plugin`).
    pub fn with_receiver(id: ObserverId, roster: Roster, perception: Box<dyn Receiving>) -> Self {
        Self {
            agent: ObserverAgent::new(id.clone(), roster),
            id,
            perception,
            parser: FrameParser::new(),
            next_token_seq: 0,
            frames_released: 0,
            stream_broken: false,
            assignment: None,
            ended: false,
        }
    }

    /// This observer's session sends frames carrying `check`: its receiver and the status
    /// mirror parse them so (set before the first tick).
    #[must_use]
    pub fn with_frame_check(mut self, check: proto::FrameCheck) -> Self {
        self.perception.set_frame_check(check);
        self.parser = FrameParser::with_check(check);
        self
    }

    pub fn id(&self) -> &ObserverId {
        &self.id
    }

    /// Why the receiving chain stopped working, once it has (see [`Receiving::failure`]).
    pub fn receiver_failure(&self) -> Option<String> {
        self.perception.failure()
    }

    /// True once the session said the mission is over.
    pub fn ended(&self) -> bool {
        self.ended
    }

    /// True while a reception window is open.
    pub fn receiving(&self) -> bool {
        self.agent.receiving()
    }

    /// Applies one tick's session controls, in order.
    pub fn apply_session(&mut self, controls: &[SessionControl]) {
        for c in controls {
            if let SessionEvent::RoundReset { .. } = c.event {
                self.assignment = None;
            }
            if c.event == SessionEvent::MissionEnd {
                self.ended = true;
            }
            if self.agent.on_session(c.event) {
                self.perception.reset();
                self.parser.interrupt();
            }
        }
    }

    /// How far the observer's airframe has turned from its home attitude (its attitude
    /// estimate), undone by perception from the next packet on ([`proto::stabilise`]).
    pub fn set_ego_rotation(&mut self, ego: Option<proto::EgoRotation>) {
        self.perception.set_ego_rotation(ego);
    }

    /// Consumes tick `tick`'s data and returns what to publish.
    pub fn step(&mut self, tick: u64, data: TickData<'_>) -> Result<TickReport, PerceptionError> {
        let now_ns = tick.saturating_mul(TICK_NS);
        let mut report = TickReport {
            tokens: Vec::new(),
            frames: Vec::new(),
            decision: None,
            status: self.status(tick, InputState::Received),
            track: None,
        };
        let input = match data {
            TickData::Nothing => InputState::Received,
            TickData::Packet(p) => {
                self.stream_broken = false;
                let valid = p.valid();
                if self.agent.receiving() {
                    let (step, pos_px) = self.perception.push_tracked(p)?;
                    report.track = Some(ObserverTrack {
                        observer: self.id.clone(),
                        tick,
                        samples: vec![TrackSample {
                            stamp_ns: now_ns,
                            pos_px,
                        }],
                    });
                    self.absorb(step, now_ns, &mut report);
                }
                if valid {
                    InputState::Received
                } else {
                    InputState::Invalid
                }
            }
            TickData::Missing => {
                if !self.stream_broken && self.agent.receiving() {
                    let step = self.perception.missing(now_ns)?;
                    self.parser.interrupt();
                    self.absorb(step, now_ns, &mut report);
                }
                self.stream_broken = true;
                InputState::Missing
            }
        };
        report.status = self.status(tick, input);
        report.status.decision = report.decision.clone();
        Ok(report)
    }

    fn absorb(&mut self, step: DecodeStep, now_ns: u64, report: &mut TickReport) {
        for t in &step.tokens {
            self.parser.push_segment(t);
            report.tokens.push(TokenEvent {
                observer: self.id.clone(),
                seq: self.next_token_seq,
                token: t.token,
                confirmed_ns: t.stamp_ns,
            });
            self.next_token_seq += 1;
        }
        if step.frames.is_empty() {
            return;
        }
        let (frames, decision) = self.agent.on_frames(&step.frames, now_ns);
        self.frames_released += frames.len() as u64;
        report.frames.extend(frames.into_iter().map(|f| FrameEvent {
            observer: self.id.clone(),
            seq: f.seq,
            round: f.round,
            frame: f.frame,
        }));
        if let Some(d) = decision {
            self.assignment = Some(d.assignment);
            report.decision = Some(d);
        }
    }

    fn status(&self, tick: u64, input: InputState) -> ObserverStatus {
        let phase = if self.ended {
            ObserverPhase::Ended
        } else if self.assignment.is_some() {
            ObserverPhase::Decided
        } else if self.agent.receiving() {
            ObserverPhase::Receiving
        } else {
            ObserverPhase::Idle
        };
        ObserverStatus {
            observer: self.id.clone(),
            tick,
            round: self.agent.round(),
            phase,
            input,
            parser_progress: u8::try_from(self.parser.progress()).unwrap_or(u8::MAX),
            tokens: self.next_token_seq,
            frames: self.frames_released,
            assignment: self.assignment.flatten(),
            decision: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::EventPacket;

    fn runtime() -> ObserverRuntime {
        ObserverRuntime::new(
            ObserverId::new("O1").unwrap(),
            Roster::default_scene(3),
            Modality::Events,
        )
        .unwrap()
    }

    fn empty_packet(tick: u64) -> EventPacket {
        EventPacket::from_events(
            tick - 1,
            ((tick - 1) * TICK_NS, tick * TICK_NS),
            (proto::scene::IMAGE_WIDTH_PX, proto::scene::IMAGE_HEIGHT_PX),
            &[],
        )
    }

    fn control(tick: u64, event: SessionEvent) -> SessionControl {
        SessionControl {
            tick,
            stamp_ns: tick * TICK_NS,
            event,
        }
    }

    #[test]
    fn phases_and_input_states_follow_the_session_and_the_stream() {
        let mut r = runtime();
        let s = r.step(0, TickData::Nothing).unwrap().status;
        assert_eq!(
            (s.phase, s.input, s.tick),
            (ObserverPhase::Idle, InputState::Received, 0)
        );
        r.apply_session(&[
            control(0, SessionEvent::RoundReset { round: 1 }),
            control(0, SessionEvent::WindowOpen { round: 1 }),
        ]);
        let p = empty_packet(1);
        let s = r
            .step(1, TickData::Packet(SensorInput::Events(&p)))
            .unwrap()
            .status;
        assert_eq!(
            (s.phase, s.input, s.round),
            (ObserverPhase::Receiving, InputState::Received, 1)
        );
        let s = r.step(2, TickData::Missing).unwrap().status;
        assert_eq!(s.input, InputState::Missing);
        let mut invalid = empty_packet(3);
        invalid.valid = false;
        let s = r
            .step(3, TickData::Packet(SensorInput::Events(&invalid)))
            .unwrap()
            .status;
        assert_eq!(s.input, InputState::Invalid);
        r.apply_session(&[control(3, SessionEvent::MissionEnd)]);
        assert!(r.ended());
        assert_eq!(
            r.step(4, TickData::Nothing).unwrap().status.phase,
            ObserverPhase::Ended
        );
    }

    #[test]
    fn a_track_sample_is_reported_only_for_packets_perception_saw() {
        let mut r = runtime();
        let p = empty_packet(1);
        assert_eq!(
            r.step(1, TickData::Packet(SensorInput::Events(&p)))
                .unwrap()
                .track,
            None,
            "no window open: perception is not fed"
        );
        r.apply_session(&[
            control(1, SessionEvent::RoundReset { round: 1 }),
            control(1, SessionEvent::WindowOpen { round: 1 }),
        ]);
        let p = empty_packet(2);
        let track = r
            .step(2, TickData::Packet(SensorInput::Events(&p)))
            .unwrap()
            .track
            .expect("a track while receiving");
        assert_eq!((track.tick, track.observer.as_str()), (2, "O1"));
        assert_eq!(
            track.samples,
            [TrackSample {
                stamp_ns: 2 * TICK_NS,
                pos_px: None
            }]
        );
        proto::decode::<ObserverTrack>(&proto::encode(&track)).unwrap();
        assert_eq!(r.step(3, TickData::Missing).unwrap().track, None);
    }

    #[test]
    fn a_sensor_of_the_wrong_kind_is_an_error_not_a_panic() {
        let mut r = runtime();
        r.apply_session(&[
            control(0, SessionEvent::RoundReset { round: 1 }),
            control(0, SessionEvent::WindowOpen { round: 1 }),
        ]);
        let frame = proto::RgbFrame {
            seq: 0,
            stamp_ns: TICK_NS,
            width: 1,
            height: 1,
            valid: true,
            continuous: true,
            rgb: vec![0; 3],
        };
        assert!(
            r.step(1, TickData::Packet(SensorInput::Rgb(&frame)))
                .is_err()
        );
    }
}
