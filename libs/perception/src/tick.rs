//! The sans-IO tick assembler: what an observer has in hand decides which tick it processes next
//! and with what (docs/DESIGN.md §3). The `observer-node` process, `waggle replay` and the
//! in-process mission all drive one [`TickAssembler`], so they assemble the observer's input
//! identically.
//!
//! # Protocol
//!
//! Tick k (`k = 0, 1, …`) is processed once
//! 1. the session controls of tick k−1 have been applied (for k ≥ 1; they apply *before*
//!    packet k, docs/DESIGN.md §3),
//! 2. `clock{k}` has arrived, and
//! 3. packet k is in hand — or is judged missing.
//!
//! Tick 0 covers no sensor interval: it is processed with [`TickInput::Nothing`] (a packet of
//! tick 0, if any, is dropped). A packet that has not arrived is missing when the camera said it
//! dropped it (decided inside, [`MissingReason::Dropped`]: a throttled camera's notice, so the
//! verdict depends on what arrived, never on when), when a *later* packet arrived (decided
//! inside, [`MissingReason::LaterPacket`]), or when the caller's judge says so:
//! the camera's liveliness token is gone, the wall-clock grace period expired, the recording
//! ended, the sensor dropped out. The assembler holds **no clock**: a shell that needs wall time
//! (the observer process's grace period) keeps its own `Instant`s and consults them in the judge.
//!
//! # Feeding it
//!
//! - [`TickAssembler::clock`]: `clock{k}` arrived (the process); or
//!   [`TickAssembler::clocks_through`]: every clock up to k is known (a recording's watermark,
//!   the in-process mission's lockstep);
//! - [`TickAssembler::session`]: the session controls of tick k (one `sched/session` message;
//!   a repeat of a tick not yet applied replaces it, one already applied is ignored);
//! - [`TickAssembler::dropped`]: the camera's notice that it dropped packet k;
//! - [`TickAssembler::packet`]: one sensor packet, placed on tick `stamp_ns / TICK_NS` (RGB) or
//!   `end_ns / TICK_NS` (events); a packet of a tick already processed is stale and dropped (it
//!   still counts as "a later packet arrived" for the ticks before it), a repeat of a buffered
//!   tick replaces it.
//!
//! # Draining it
//!
//! [`TickAssembler::next_step`] returns the next ready [`Step`] and advances past it, or `None`
//! when it must wait for more input ([`TickAssembler::waiting`] says for what). The caller acts
//! on every step in order:
//!
//! ```
//! use perception::tick::{MissingReason, Step, TickAssembler};
//! # use perception::runtime::ObserverRuntime;
//! # use proto::{Modality, ObserverId, Roster};
//! # let mut runtime = ObserverRuntime::new(
//! #     ObserverId::new("O1").unwrap(), Roster::default_scene(3), Modality::Events).unwrap();
//! let mut assembler = TickAssembler::new();
//! assembler.clock(0);
//! assembler.session(0, Vec::new());
//! assembler.clock(1);
//! let camera_gone = true; // e.g. from the camera's liveliness token
//! while let Some(step) =
//!     assembler.next_step(|_tick| camera_gone.then_some(MissingReason::CameraGone))
//! {
//!     match step {
//!         Step::Session { controls, .. } => {
//!             runtime.apply_session(&controls);
//!             if runtime.ended() {
//!                 break;
//!             }
//!         }
//!         Step::Tick { tick, input } => {
//!             let report = runtime.step(tick, input.data()).unwrap();
//!             // … publish the report …
//!         }
//!     }
//! }
//! assert_eq!(assembler.next_tick(), 2);
//! ```
//!
//! How each caller judges a packet that has not arrived (and no later packet has):
//! - the observer process: [`MissingReason::CameraGone`] when the camera's liveliness token is
//!   gone, else [`MissingReason::GraceExpired`] once `--grace-ms` passed since `clock{k}`
//!   arrived, else `None` (wait). The grace period is a last resort for a camera that is alive
//!   but neither sends packet k nor says it dropped it (a stuck process, a message lost with a
//!   live link); no fault Waggle injects relies on it;
//! - replay: [`MissingReason::EndOfRecording`] once the whole recording is read, else `None`;
//! - the in-process mission: every packet is present, or [`MissingReason::Dropout`] when the
//!   case's fault removed the stream.
//!
//! Whether the runtime ended (`MissionEnd`) is the caller's business: it stops draining.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;

use proto::{EventPacket, RgbFrame, Sample, SessionControl, TICK_NS};

use crate::runtime::TickData;
use crate::sensing::SensorInput;

/// One packet of the observer's own sensor, owned while it waits for its tick.
#[derive(Debug, Clone, PartialEq)]
pub enum SensorPacket {
    Rgb(RgbFrame),
    Events(EventPacket),
    /// An already tracked target position at a tick boundary (the ideal baseline).
    Track(Sample),
}

impl SensorPacket {
    /// The tick this packet belongs to: an RGB frame rendered at `stamp_ns`, or the event packet
    /// ending at `end_ns`, is packet `t / TICK_NS`.
    pub fn tick(&self) -> u64 {
        match self {
            SensorPacket::Rgb(f) => f.tick(),
            SensorPacket::Events(p) => p.tick(),
            SensorPacket::Track(s) => s.stamp_ns / TICK_NS,
        }
    }

    /// The packet as perception input.
    pub fn input(&self) -> SensorInput<'_> {
        match self {
            SensorPacket::Rgb(f) => SensorInput::Rgb(f),
            SensorPacket::Events(p) => SensorInput::Events(p),
            SensorPacket::Track(s) => SensorInput::Track(s),
        }
    }
}

impl From<RgbFrame> for SensorPacket {
    fn from(f: RgbFrame) -> Self {
        SensorPacket::Rgb(f)
    }
}

impl From<Sample> for SensorPacket {
    fn from(s: Sample) -> Self {
        SensorPacket::Track(s)
    }
}

impl From<EventPacket> for SensorPacket {
    fn from(p: EventPacket) -> Self {
        SensorPacket::Events(p)
    }
}

/// Why a tick's packet was judged missing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MissingReason {
    /// A packet of a later tick arrived (decided by the assembler).
    LaterPacket,
    /// The camera said it dropped the packet (decided by the assembler, from the camera's
    /// `sensor/<o>/dropped` notice).
    Dropped,
    /// The camera's liveliness token is gone (observer process).
    CameraGone,
    /// The wall-clock grace period after `clock{k}` expired (observer process).
    GraceExpired,
    /// The recording holds nothing more (replay).
    EndOfRecording,
    /// The sensor stream dropped out (in-process mission fault).
    Dropout,
    /// The sensor link lost it (in-process mission, a lossy-link perturbation).
    Lost,
}

impl MissingReason {
    /// A short phrase for logs ("a later packet arrived", "the camera is gone", …).
    pub fn as_str(self) -> &'static str {
        match self {
            MissingReason::LaterPacket => "a later packet arrived",
            MissingReason::Dropped => "the camera dropped it",
            MissingReason::CameraGone => "the camera is gone",
            MissingReason::GraceExpired => "grace period expired",
            MissingReason::EndOfRecording => "the recording ended",
            MissingReason::Dropout => "the sensor stream dropped out",
            MissingReason::Lost => "the link lost it",
        }
    }
}

impl fmt::Display for MissingReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// What tick k is processed with (the owned counterpart of [`TickData`]).
#[derive(Debug, Clone, PartialEq)]
pub enum TickInput {
    /// Tick 0: nothing is expected.
    Nothing,
    /// Packet k, in hand.
    Packet(SensorPacket),
    /// Packet k was judged missing, and why.
    Missing(MissingReason),
}

impl TickInput {
    /// The runtime's view of it, for [`crate::runtime::ObserverRuntime::step`].
    pub fn data(&self) -> TickData<'_> {
        match self {
            TickInput::Nothing => TickData::Nothing,
            TickInput::Packet(p) => TickData::Packet(p.input()),
            TickInput::Missing(_) => TickData::Missing,
        }
    }

    /// Why the packet is missing (`None` unless [`TickInput::Missing`]).
    pub fn missing(&self) -> Option<MissingReason> {
        match self {
            TickInput::Missing(why) => Some(*why),
            _ => None,
        }
    }
}

/// The next thing the observer must do, in order.
#[derive(Debug, Clone, PartialEq)]
pub enum Step {
    /// Apply the session controls of tick `tick` (before packet `tick + 1`), in order; then
    /// stop if the runtime ended.
    Session {
        tick: u64,
        controls: Vec<SessionControl>,
    },
    /// Process tick `tick` with `input`.
    Tick { tick: u64, input: TickInput },
}

/// What the assembler needs before it can yield the next step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Waiting {
    /// The session controls of this tick.
    Session(u64),
    /// `clock{k}` of this tick.
    Clock(u64),
    /// The packet of this tick, or a verdict that it is missing.
    Packet(u64),
}

/// One observer's input assembly (see the module docs). Pure: no I/O, no clock.
#[derive(Debug, Clone, Default)]
pub struct TickAssembler {
    /// The next tick to process.
    next: u64,
    /// Session controls apply before packet k once `sessions_applied == k`.
    sessions_applied: u64,
    /// Session controls by tick, not yet applied.
    sessions: BTreeMap<u64, Vec<SessionControl>>,
    /// Packets by tick, not yet processed.
    packets: BTreeMap<u64, SensorPacket>,
    /// The latest tick any packet arrived for (stale ones included).
    latest_packet: Option<u64>,
    /// Ticks not yet processed whose packet the camera said it dropped.
    dropped: BTreeSet<u64>,
    /// Clock ticks that arrived and are not yet processed.
    clocks: BTreeSet<u64>,
    /// Every clock up to this tick is known ([`TickAssembler::clocks_through`]).
    clocks_through: Option<u64>,
}

impl TickAssembler {
    /// An assembler at tick 0, with nothing in hand.
    pub fn new() -> Self {
        Self::default()
    }

    /// The next tick to process (also the number of ticks processed so far).
    pub fn next_tick(&self) -> u64 {
        self.next
    }

    /// The latest tick any packet arrived for, if any (stale packets included).
    pub fn latest_packet(&self) -> Option<u64> {
        self.latest_packet
    }

    /// True when `clock{tick}` is known to have arrived (and `tick` is not yet processed).
    pub fn has_clock(&self, tick: u64) -> bool {
        tick >= self.next
            && (self.clocks.contains(&tick) || self.clocks_through.is_some_and(|c| c >= tick))
    }

    /// `clock{tick}` arrived. A clock of a processed tick is ignored.
    pub fn clock(&mut self, tick: u64) {
        if tick >= self.next {
            self.clocks.insert(tick);
        }
    }

    /// Every clock up to `tick` is known (a recording's watermark; lockstep callers).
    pub fn clocks_through(&mut self, tick: u64) {
        self.clocks_through = self.clocks_through.max(Some(tick));
    }

    /// The session controls of tick `tick` arrived. They are applied before packet `tick + 1`.
    /// A repeat for a tick not yet applied replaces the earlier one; controls of a tick
    /// already applied are ignored.
    pub fn session(&mut self, tick: u64, controls: Vec<SessionControl>) {
        if tick >= self.sessions_applied {
            self.sessions.insert(tick, controls);
        }
    }

    /// One packet of the observer's own sensor arrived. Returns its tick and whether it was
    /// kept: a packet of a tick already processed is stale and dropped, but still tells the
    /// assembler a later packet exists. A repeat for a buffered tick replaces the earlier one.
    pub fn packet(&mut self, packet: impl Into<SensorPacket>) -> (u64, bool) {
        let packet = packet.into();
        let tick = packet.tick();
        self.latest_packet = self.latest_packet.max(Some(tick));
        let kept = tick >= self.next;
        if kept {
            self.packets.insert(tick, packet);
        }
        (tick, kept)
    }

    /// The camera dropped its packet of `tick` (its `sensor/<o>/dropped` notice): that tick is
    /// processed as missing once otherwise ready, whenever the notice arrives relative to the
    /// other inputs. A notice for a processed tick is ignored. Should the packet itself arrive
    /// too (a contradiction only a faulty camera makes), whichever is in hand when the tick is
    /// ready wins.
    pub fn dropped(&mut self, tick: u64) {
        if tick >= self.next {
            self.dropped.insert(tick);
        }
    }

    /// What the next tick k still lacks when [`TickAssembler::next_step`] returns `None`: the
    /// session controls of tick k−1, `clock{k}`, or packet k (or a verdict that it is missing).
    /// When a step is ready it names the last of the three, [`Waiting::Packet`].
    pub fn waiting(&self) -> Waiting {
        if self.sessions_applied < self.next && !self.sessions.contains_key(&(self.next - 1)) {
            Waiting::Session(self.next - 1)
        } else if !self.has_clock(self.next) {
            Waiting::Clock(self.next)
        } else {
            Waiting::Packet(self.next)
        }
    }

    /// The next ready step, advancing past it; `None` when more input is needed.
    ///
    /// `judge(k)` is asked only when tick k is otherwise ready (its sessions applied, its clock
    /// in hand), packet k has not arrived and no later packet has: return the reason it is
    /// missing, or `None` to wait for it.
    pub fn next_step(&mut self, judge: impl FnOnce(u64) -> Option<MissingReason>) -> Option<Step> {
        let tick = self.next;
        // The session controls of tick k−1 apply before packet k (docs/DESIGN.md §3).
        if self.sessions_applied < tick {
            let controls = self.sessions.remove(&(tick - 1))?;
            self.sessions_applied = tick;
            return Some(Step::Session {
                tick: tick - 1,
                controls,
            });
        }
        if !self.has_clock(tick) {
            return None;
        }
        let packet = self.packets.remove(&tick);
        let input = match packet {
            _ if tick == 0 => TickInput::Nothing,
            Some(p) => TickInput::Packet(p),
            None if self.dropped.contains(&tick) => TickInput::Missing(MissingReason::Dropped),
            None if self.latest_packet.is_some_and(|l| l > tick) => {
                TickInput::Missing(MissingReason::LaterPacket)
            }
            None => TickInput::Missing(judge(tick)?),
        };
        self.clocks.remove(&tick);
        self.next = tick + 1;
        let next = self.next;
        self.packets.retain(|t, _| *t >= next);
        self.dropped.retain(|t| *t >= next);
        Some(Step::Tick { tick, input })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::SessionEvent;

    fn events(tick: u64) -> EventPacket {
        EventPacket::from_events(
            tick.saturating_sub(1),
            (tick.saturating_sub(1) * TICK_NS, tick * TICK_NS),
            (proto::scene::IMAGE_WIDTH_PX, proto::scene::IMAGE_HEIGHT_PX),
            &[],
        )
    }

    fn rgb(tick: u64) -> RgbFrame {
        RgbFrame {
            seq: tick,
            stamp_ns: tick * TICK_NS,
            width: 1,
            height: 1,
            valid: true,
            continuous: true,
            rgb: vec![0; 3],
        }
    }

    fn controls(tick: u64, event: SessionEvent) -> Vec<SessionControl> {
        vec![SessionControl {
            tick,
            stamp_ns: tick * TICK_NS,
            event,
        }]
    }

    fn wait(_: u64) -> Option<MissingReason> {
        None
    }

    /// Drains every ready step with a judge that never declares a packet missing.
    fn drain(a: &mut TickAssembler) -> Vec<Step> {
        std::iter::from_fn(|| a.next_step(wait)).collect()
    }

    fn tick(tick: u64, input: TickInput) -> Step {
        Step::Tick { tick, input }
    }

    fn session(tick: u64) -> Step {
        Step::Session {
            tick,
            controls: Vec::new(),
        }
    }

    #[test]
    fn tick_zero_needs_only_its_clock_and_drops_its_packet() {
        let mut a = TickAssembler::new();
        assert_eq!(a.waiting(), Waiting::Clock(0));
        assert_eq!(a.packet(events(0)), (0, true));
        assert_eq!(drain(&mut a), []);
        a.clock(0);
        assert_eq!(drain(&mut a), [tick(0, TickInput::Nothing)]);
        assert_eq!(a.next_tick(), 1);
        assert_eq!(a.waiting(), Waiting::Session(0));
        // The judge is never asked about tick 0.
        let mut b = TickAssembler::new();
        b.clock(0);
        let step = b.next_step(|_| panic!("tick 0 is never judged"));
        assert_eq!(step, Some(tick(0, TickInput::Nothing)));
    }

    #[test]
    fn session_controls_of_the_previous_tick_come_before_the_packet() {
        let mut a = TickAssembler::new();
        a.clock(0);
        a.clock(1);
        a.packet(events(1));
        assert_eq!(drain(&mut a), [tick(0, TickInput::Nothing)]);
        assert_eq!(a.waiting(), Waiting::Session(0));
        // Controls of a later tick do not unblock tick 1.
        a.session(1, controls(1, SessionEvent::MissionEnd));
        assert_eq!(drain(&mut a), []);
        a.session(0, controls(0, SessionEvent::WindowOpen { round: 1 }));
        assert_eq!(
            drain(&mut a),
            [
                Step::Session {
                    tick: 0,
                    controls: controls(0, SessionEvent::WindowOpen { round: 1 })
                },
                tick(1, TickInput::Packet(events(1).into())),
                Step::Session {
                    tick: 1,
                    controls: controls(1, SessionEvent::MissionEnd)
                },
            ]
        );
        assert_eq!(a.waiting(), Waiting::Clock(2));
    }

    #[test]
    fn a_repeated_session_replaces_an_unapplied_one_and_an_applied_one_is_ignored() {
        let mut a = TickAssembler::new();
        a.clock(0);
        a.session(0, controls(0, SessionEvent::WindowOpen { round: 1 }));
        a.session(0, Vec::new());
        assert_eq!(drain(&mut a), [tick(0, TickInput::Nothing), session(0)]);
        a.session(0, controls(0, SessionEvent::MissionEnd));
        a.clock(1);
        a.packet(events(1));
        a.session(1, Vec::new());
        assert_eq!(
            drain(&mut a),
            [tick(1, TickInput::Packet(events(1).into())), session(1)]
        );
    }

    #[test]
    fn packets_arriving_out_of_order_are_processed_in_tick_order() {
        let mut a = TickAssembler::new();
        for k in [3, 1, 2] {
            a.packet(rgb(k));
        }
        for k in [2, 0, 3, 1] {
            a.clock(k);
        }
        for k in [2, 0, 1] {
            a.session(k, Vec::new());
        }
        assert_eq!(
            drain(&mut a),
            [
                tick(0, TickInput::Nothing),
                session(0),
                tick(1, TickInput::Packet(rgb(1).into())),
                session(1),
                tick(2, TickInput::Packet(rgb(2).into())),
                session(2),
                tick(3, TickInput::Packet(rgb(3).into())),
            ]
        );
        assert_eq!(a.latest_packet(), Some(3));
    }

    #[test]
    fn a_later_packet_makes_the_gap_missing_without_asking_the_judge() {
        let mut a = TickAssembler::new();
        a.clock(0);
        a.clock(1);
        a.clock(2);
        a.session(0, Vec::new());
        a.session(1, Vec::new());
        assert_eq!(drain(&mut a), [tick(0, TickInput::Nothing), session(0)]);
        assert_eq!(a.waiting(), Waiting::Packet(1));
        a.packet(events(2));
        let step = a.next_step(|_| panic!("a later packet decides alone"));
        assert_eq!(
            step,
            Some(tick(1, TickInput::Missing(MissingReason::LaterPacket)))
        );
        assert_eq!(
            drain(&mut a),
            [session(1), tick(2, TickInput::Packet(events(2).into()))]
        );
    }

    /// The inputs of ticks 0–3 where the camera dropped packet 2, in every order the lockstep
    /// allows: tick k's inputs (the session controls of k−1, `clock{k}`, packet k or the drop
    /// notice) exist only once tick k−1 is processed, but arrive among themselves in any order.
    /// The steps never change, and the judge (the wall clock's stand-in) never decides one.
    #[test]
    fn a_drop_notice_decides_alone_in_every_arrival_order() {
        #[derive(Clone, Copy)]
        enum In {
            Clock(u64),
            Session(u64),
            Packet(u64),
            Dropped(u64),
        }
        fn orders(group: [In; 3]) -> Vec<[In; 3]> {
            let [a, b, c] = group;
            vec![
                [a, b, c],
                [a, c, b],
                [b, a, c],
                [b, c, a],
                [c, a, b],
                [c, b, a],
            ]
        }
        let want = [
            tick(0, TickInput::Nothing),
            session(0),
            tick(1, TickInput::Packet(events(1).into())),
            session(1),
            tick(2, TickInput::Missing(MissingReason::Dropped)),
            session(2),
            tick(3, TickInput::Packet(events(3).into())),
        ];
        let groups = [
            [In::Session(0), In::Clock(1), In::Packet(1)],
            [In::Session(1), In::Clock(2), In::Dropped(2)],
            [In::Session(2), In::Clock(3), In::Packet(3)],
        ];
        let mut runs = 0;
        for g1 in orders(groups[0]) {
            for g2 in orders(groups[1]) {
                for g3 in orders(groups[2]) {
                    let mut a = TickAssembler::new();
                    a.clock(0);
                    let mut got = drain(&mut a);
                    for input in g1.into_iter().chain(g2).chain(g3) {
                        match input {
                            In::Clock(k) => a.clock(k),
                            In::Session(k) => a.session(k, Vec::new()),
                            In::Packet(k) => {
                                a.packet(events(k));
                            }
                            In::Dropped(k) => a.dropped(k),
                        }
                        // The judge only ever says "wait": what is decided, the inputs decided.
                        got.extend(drain(&mut a));
                    }
                    assert_eq!(got, want);
                    runs += 1;
                }
            }
        }
        assert_eq!(runs, 216);
    }

    #[test]
    fn the_judge_decides_a_packet_with_no_later_one_and_is_asked_for_that_tick() {
        let mut a = TickAssembler::new();
        a.clock(0);
        a.clock(1);
        a.session(0, Vec::new());
        assert_eq!(drain(&mut a), [tick(0, TickInput::Nothing), session(0)]);
        assert_eq!(a.waiting(), Waiting::Packet(1));
        let mut asked = Vec::new();
        assert_eq!(
            a.next_step(|k| {
                asked.push(k);
                None
            }),
            None
        );
        assert_eq!(a.next_tick(), 1, "waiting does not advance");
        for why in [
            MissingReason::CameraGone,
            MissingReason::GraceExpired,
            MissingReason::EndOfRecording,
            MissingReason::Dropout,
        ] {
            let mut b = a.clone();
            let step = b.next_step(|k| {
                asked.push(k);
                Some(why)
            });
            assert_eq!(step, Some(tick(1, TickInput::Missing(why))));
            let Some(Step::Tick { input, .. }) = step else {
                unreachable!()
            };
            assert_eq!(input.missing(), Some(why));
            assert!(matches!(input.data(), TickData::Missing));
        }
        assert_eq!(asked, [1; 5]);
        // The judge is not asked while the clock or the session controls are missing.
        let mut b = TickAssembler::new();
        assert_eq!(b.next_step(|_| panic!("no clock yet")), None);
        b.clock(0);
        b.clock(1);
        b.next_step(wait);
        assert_eq!(b.next_step(|_| panic!("no session yet")), None);
    }

    #[test]
    fn stale_and_duplicate_packets() {
        let mut a = TickAssembler::new();
        a.clock(0);
        a.clock(1);
        a.session(0, Vec::new());
        let mut first = events(1);
        first.valid = false;
        assert_eq!(a.packet(first), (1, true));
        // A repeat of a buffered tick replaces it.
        assert_eq!(a.packet(events(1)), (1, true));
        assert_eq!(
            drain(&mut a),
            [
                tick(0, TickInput::Nothing),
                session(0),
                tick(1, TickInput::Packet(events(1).into())),
            ]
        );
        // A packet of a processed tick is stale: dropped, never processed.
        assert_eq!(a.packet(events(1)), (1, false));
        assert_eq!(a.packet(events(0)), (0, false));
        a.session(1, Vec::new());
        a.clock(2);
        assert_eq!(drain(&mut a), [session(1)]);
        assert_eq!(a.waiting(), Waiting::Packet(2));
        // A stale clock is ignored.
        a.clock(1);
        assert!(!a.has_clock(1));
        assert!(a.has_clock(2));
    }

    #[test]
    fn a_stale_packet_still_counts_as_a_later_one_for_the_ticks_before_it() {
        // Only possible in principle (the tick before a stale one is already processed), but
        // `latest_packet` counts every packet that arrived, as the process always did.
        let mut a = TickAssembler::new();
        a.clock(0);
        a.next_step(wait);
        a.packet(events(0));
        assert_eq!(a.latest_packet(), Some(0));
        a.packet(events(5));
        assert_eq!(a.latest_packet(), Some(5));
        a.packet(events(3));
        assert_eq!(a.latest_packet(), Some(5));
    }

    #[test]
    fn a_clock_watermark_stands_for_every_clock_up_to_it() {
        let mut a = TickAssembler::new();
        a.clocks_through(2);
        for k in 0..3 {
            a.session(k, Vec::new());
            a.packet(events(k));
        }
        assert_eq!(
            drain(&mut a),
            [
                tick(0, TickInput::Nothing),
                session(0),
                tick(1, TickInput::Packet(events(1).into())),
                session(1),
                tick(2, TickInput::Packet(events(2).into())),
                session(2),
            ]
        );
        assert_eq!(a.waiting(), Waiting::Clock(3));
        a.clocks_through(1);
        assert_eq!(
            a.waiting(),
            Waiting::Clock(3),
            "a watermark never goes back"
        );
        a.clock(3);
        assert_eq!(a.waiting(), Waiting::Packet(3));
        let step = a.next_step(|_| Some(MissingReason::EndOfRecording));
        assert_eq!(
            step,
            Some(tick(3, TickInput::Missing(MissingReason::EndOfRecording)))
        );
    }

    #[test]
    fn packets_place_themselves_on_their_tick() {
        let mut e = events(7);
        assert_eq!(SensorPacket::from(e.clone()).tick(), 7);
        e.end_ns += TICK_NS - 1;
        assert_eq!(SensorPacket::from(e).tick(), 7);
        let mut f = rgb(4);
        assert_eq!(SensorPacket::from(f.clone()).tick(), 4);
        f.stamp_ns -= 1;
        assert_eq!(SensorPacket::from(f).tick(), 3);
        assert_eq!(
            MissingReason::LaterPacket.to_string(),
            "a later packet arrived"
        );
    }
}
