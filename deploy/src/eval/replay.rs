//! `waggle replay DIR/session.mcap [--json]`: the receivers re-run from a recording.
//!
//! Loads no MuJoCo scene. For each observer it feeds a fresh [`ObserverRuntime`] — the very
//! code path `observer-node` runs — with that observer's recorded raw sensor input (event
//! packets, or the RGB camera's key frames and changed rectangles, rebuilt into whole frames;
//! a recording of a noisy session keeps the event sensors' input instead, and the packets are
//! regenerated from it, [`crate::eval::regenerate`], and must equal the ones received live)
//! and the recorded session controls (reception windows, round resets, mission end), tick by
//! tick in the observer process's order: the controls of tick k−1, then packet k, or "missing"
//! when the recording holds no packet k (a later packet of that camera exists, or the recording
//! ends). It then compares every released payload and final-NULL time — and, more strictly,
//! every token, decision and per-tick input state — with the live decodes recorded on
//! `observer/Oi/{frames,tokens,decision,status}`. Any mismatch fails.
//!
//! A damaged or cut recording is compared only where it covers the run: for each observer, up
//! to the last tick whose sensor input and live status both survive (and before the first
//! damaged stretch). The report says so (`partial`, `covered_through_s`); a mismatch inside
//! that range is still a mismatch.

use std::collections::BTreeMap;

use anyhow::{Context, Result, bail};
use perception::observer::{ObserverCore, Processed};
use perception::runtime::ObserverRuntime;
use perception::tick::MissingReason;
use proto::Modality;
use proto::{
    Decision, EventPacket, FrameEvent, InputState, ObserverId, RgbReassembler, RgbUpdate, Roster,
    SessionControl, TICK_NS, TokenEvent,
};
use recording::Decoded;
use serde::Serialize;

use crate::eval::regenerate::{Regenerated, Regenerator};
use run_eval::recording::received;
use run_eval::recording::{Item, resolve, scan, topic_key, topic_observer};
use run_eval::summary::ns_s;

/// One observer's replay against its live decodes.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct ObserverReplay {
    pub payloads_matched: usize,
    pub payloads_live: usize,
    pub payloads_replayed: usize,
    /// Frames whose payload or final-NULL time differ, or that only one side released.
    pub mismatches: Vec<String>,
    pub tokens_live: usize,
    pub tokens_replayed: usize,
    /// Every token (kind, sequence, confirmation time) equal.
    pub tokens_identical: bool,
    /// Every decision (round, time, assignment, sources, allocation) equal.
    pub decisions_identical: bool,
    /// Ticks whose input state (received / invalid / missing) differs from the live status.
    pub input_disagreements: Vec<u64>,
    pub ticks_replayed: u64,
    pub packets: u64,
    pub events: u64,
    /// RGB updates that built on a frame the recording does not hold (treated as missing).
    pub unassembled: u64,
    /// The last tick compared (`None`: the whole run).
    pub covered_through_tick: Option<u64>,
    /// The recording kept the camera's input: its packets regenerated, against the ones the
    /// recorder received.
    pub regenerated: Option<Regenerated>,
}

/// What `waggle replay --json` prints.
#[derive(Debug, Clone, Serialize)]
pub struct ReplayReport {
    /// The recording is cut or damaged: each observer is compared up to its
    /// `covered_through_tick`.
    pub partial: bool,
    /// Why, when partial.
    pub partial_reason: Option<String>,
    /// `rgb` or `events`.
    pub modality: String,
    pub observers: BTreeMap<String, ObserverReplay>,
    pub all_matched: bool,
}

/// One observer's receiver driven exactly as `observer-node`'s main loop drives it: the
/// observer core ([`ObserverCore`]: the tick assembler and runtime) orders the recorded session controls and sensor
/// packets, the recording's clock is its watermark, and its end judges a packet missing. Every
/// output is kept with the tick that produced it, so a partial recording can be compared up to
/// where it covers the run.
struct Replayer {
    core: ObserverCore,
    done: bool,
    tokens: Vec<(u64, TokenEvent)>,
    frames: Vec<(u64, FrameEvent)>,
    decisions: Vec<(u64, Decision)>,
    inputs: BTreeMap<u64, InputState>,
    packets_seen: u64,
    events_seen: u64,
    /// Rebuilds RGB frames from the recorded updates (RGB sessions).
    rgb: RgbReassembler,
    unassembled: u64,
    last_packet_tick: Option<u64>,
}

impl Replayer {
    fn new(
        id: ObserverId,
        observers: usize,
        modality: Modality,
        check: proto::FrameCheck,
    ) -> Result<Self> {
        Ok(Self {
            core: ObserverCore::new(
                ObserverRuntime::new(id, Roster::default_scene(observers), modality)
                    .context("building the receiver")?
                    .with_frame_check(check),
            ),
            done: false,
            tokens: Vec::new(),
            frames: Vec::new(),
            decisions: Vec::new(),
            inputs: BTreeMap::new(),
            packets_seen: 0,
            events_seen: 0,
            rgb: RgbReassembler::default(),
            unassembled: 0,
            last_packet_tick: None,
        })
    }

    fn packet(&mut self, p: EventPacket) {
        self.packets_seen += 1;
        self.events_seen += p.len() as u64;
        let (tick, _) = self.core.packet(p);
        self.last_packet_tick = self.last_packet_tick.max(Some(tick));
    }

    fn rgb_update(&mut self, u: RgbUpdate) {
        match self.rgb.apply(u) {
            Ok(frame) => {
                self.packets_seen += 1;
                let (tick, _) = self.core.packet(frame);
                self.last_packet_tick = self.last_packet_tick.max(Some(tick));
            }
            // Its base frame is not in the recording (damage): the tick is judged missing.
            Err(_) => self.unassembled += 1,
        }
    }

    /// Advances as far as the recording read so far allows (`last_clock`: the latest recorded
    /// clock tick; `eof`: nothing more will come).
    fn advance(&mut self, last_clock: Option<u64>, eof: bool) -> Result<()> {
        if let Some(c) = last_clock {
            self.core.clocks_through(c);
        }
        let judge = |_tick| eof.then_some(MissingReason::EndOfRecording);
        while !self.done {
            let Some(Processed {
                tick,
                input: _,
                report,
            }) = self.core.next(judge).context("replaying a tick")?
            else {
                // Ended, or waiting for session controls or a clock the recording does not hold.
                self.done = eof || self.core.ended();
                return Ok(());
            };
            self.tokens
                .extend(report.tokens.into_iter().map(|t| (tick, t)));
            self.frames
                .extend(report.frames.into_iter().map(|f| (tick, f)));
            self.decisions
                .extend(report.decision.into_iter().map(|d| (tick, d)));
            self.inputs.insert(tick, report.status.input);
        }
        Ok(())
    }
}

#[derive(Default)]
struct Live {
    tokens: Vec<TokenEvent>,
    frames: Vec<FrameEvent>,
    decisions: Vec<Decision>,
    inputs: BTreeMap<u64, InputState>,
}

impl Live {
    fn last_status_tick(&self) -> Option<u64> {
        self.inputs.keys().next_back().copied()
    }
}

/// Everything a replay gathers while it reads the recording.
struct Replay {
    replayers: BTreeMap<ObserverId, Replayer>,
    live: BTreeMap<ObserverId, Live>,
    sessions_all: BTreeMap<u64, Vec<SessionControl>>,
    last_clock: Option<u64>,
    whole_rgb_frames: u64,
    /// Observers of the session (the scene's most when unknown).
    n: usize,
    modality: Modality,
    /// The session's frame check (the recorded case's; none when it holds no case).
    check: proto::FrameCheck,
    /// The event packets' source when the recording kept the sensors' input.
    regenerator: Option<Regenerator>,
}

impl Replay {
    fn replayer(&mut self, o: &ObserverId) -> Result<&mut Replayer> {
        replayer(
            &mut self.replayers,
            o,
            self.n,
            self.modality,
            self.check,
            &self.sessions_all,
        )
    }

    /// Takes one recorded message and advances every receiver as far as it allows.
    fn take(&mut self, item: Item<'_>) -> Result<()> {
        let observer = || {
            topic_observer(item.topic)
                .with_context(|| format!("no observer in topic {}", item.topic))
        };
        match item.msg {
            Decoded::Clock(c) => self.last_clock = self.last_clock.max(Some(c.tick)),
            Decoded::SessionTick(s) => {
                for r in self.replayers.values_mut() {
                    r.core.session(s.tick, s.controls.clone());
                }
                self.sessions_all.insert(s.tick, s.controls);
            }
            Decoded::RgbUpdate(u) if is_input(item.topic) => {
                if let Some(regen) = self.regenerator.as_mut() {
                    let o = observer()?;
                    let released = regen.input(&o, u)?;
                    let r = self.replayer(&o)?;
                    for p in released {
                        r.packet(p);
                    }
                }
            }
            Decoded::EventPacket(p) if self.modality == Modality::Events => {
                self.replayer(&observer()?)?.packet(p);
            }
            Decoded::RgbUpdate(u) if self.modality == Modality::Rgb => {
                self.replayer(&observer()?)?.rgb_update(u);
            }
            // The camera's word that it dropped a packet decides that tick as it did live,
            // without waiting for the next packet or the end of the recording.
            // A notice naming another observer than its topic was refused live; so here.
            Decoded::PacketDropped(d)
                if topic_observer(item.topic).as_ref() == Some(&d.observer) =>
            {
                if let Some(regen) = self.regenerator.as_mut() {
                    regen.dropped(&d.observer, d.seq)?;
                }
                self.replayer(&d.observer)?.core.dropped(d.tick);
            }
            Decoded::RgbFrame(_) => self.whole_rgb_frames += 1,
            msg => self.take_live(msg),
        }
        for r in self.replayers.values_mut() {
            r.advance(self.last_clock, false)?;
        }
        Ok(())
    }

    /// Keeps what the observers published live.
    fn take_live(&mut self, msg: Decoded) {
        fn of<'a>(live: &'a mut BTreeMap<ObserverId, Live>, o: &ObserverId) -> &'a mut Live {
            live.entry(o.clone()).or_default()
        }
        let live = &mut self.live;
        match msg {
            Decoded::FrameEvent(f) => of(live, &f.observer).frames.push(f),
            Decoded::TokenEvent(t) => of(live, &t.observer).tokens.push(t),
            Decoded::Decision(d) => of(live, &d.observer).decisions.push(d),
            Decoded::ObserverStatus(s) => {
                of(live, &s.observer).inputs.insert(s.tick, s.input);
            }
            _ => {}
        }
    }

    /// The recording has ended: the regenerated packets still held go to their receivers, and
    /// each camera's packets made are set against those received.
    fn finish_regeneration(
        &mut self,
        metadata: &BTreeMap<String, BTreeMap<String, String>>,
    ) -> Result<BTreeMap<String, Regenerated>> {
        let Some(mut regen) = self.regenerator.take() else {
            return Ok(BTreeMap::new());
        };
        for (o, packets) in regen.finish() {
            let r = self.replayer(&o)?;
            for p in packets {
                r.packet(p);
            }
        }
        Ok(regen.compare(received(metadata)?.as_ref()))
    }
}

/// Replays the recording at `path` and compares with its live decodes.
pub fn replay_recording(path: &std::path::Path) -> Result<ReplayReport> {
    let info = recording::leading_metadata(&resolve(path), recording::SESSION_METADATA)?
        .map(|m| recording::SessionInfo::from_metadata(&m));
    let observers = info.as_ref().map(|i| i.observers).filter(|n| *n > 0);
    let recorded_modality = info.as_ref().and_then(|i| i.modality.clone());
    let modality = match recorded_modality.as_deref() {
        Some("rgb") => Modality::Rgb,
        _ => Modality::Events,
    };
    // The receivers must release exactly the frames the live ones did, so they take the
    // session's frame check from the case the recording holds.
    let check = match info.as_ref().and_then(|i| i.case_toml.as_deref()) {
        Some(text) => {
            toml::from_str::<run_format::case::Case>(text)
                .context("parsing the case stored in the recording")?
                .frame_check
        }
        None => proto::FrameCheck::None,
    };
    let mut replay = Replay {
        replayers: BTreeMap::new(),
        live: BTreeMap::new(),
        sessions_all: BTreeMap::new(),
        last_clock: None,
        whole_rgb_frames: 0,
        n: observers.unwrap_or(proto::scene::MAX_OBSERVERS),
        modality,
        check,
        regenerator: match (&info, modality) {
            (Some(info), Modality::Events) => Regenerator::of(info)?,
            _ => None,
        },
    };
    let scanned = scan(path, |item| replay.take(item))?;
    let regenerated = replay.finish_regeneration(&scanned.outcome.metadata)?;
    if replay.replayers.is_empty() {
        if replay.whole_rgb_frames > 0 {
            bail!(
                "this RGB recording holds one whole frame in 25 (made before every RGB update was \
                 recorded): the RGB receivers cannot be replayed from it; record it again"
            );
        }
        bail!(
            "the recording holds no {} sensor input: nothing to replay",
            match modality {
                Modality::Rgb => "RGB",
                Modality::Events => "event",
            }
        );
    }
    let partial = !scanned.outcome.complete;
    let mut report = ReplayReport {
        partial,
        partial_reason: scanned.outcome.problem.clone(),
        modality: match modality {
            Modality::Rgb => "rgb",
            Modality::Events => "events",
        }
        .to_string(),
        observers: BTreeMap::new(),
        all_matched: true,
    };
    let first_damage_tick = scanned
        .outcome
        .first_damage_ns
        .map(|t| (t / TICK_NS).saturating_sub(1));
    for (id, r) in &mut replay.replayers {
        r.advance(replay.last_clock, true)?;
        let l = replay.live.remove(id).unwrap_or_default();
        // Where the recording covers this observer: its input and its live outputs both
        // survive, and nothing before is damaged.
        let horizon = partial.then(|| {
            [r.last_packet_tick, l.last_status_tick(), first_damage_tick]
                .into_iter()
                .flatten()
                .min()
                .unwrap_or(0)
        });
        let mut o = compare(r, l, horizon);
        o.regenerated = regenerated.get(id.as_str()).cloned();
        // A cut or damaged recording is judged by its decodes up to where it covers the run:
        // the regeneration cannot follow a lost render, and a cut one holds no account of what
        // was received.
        let regeneration_differs = !partial
            && o.regenerated.as_ref().is_some_and(|g| {
                g.unassembled > 0 || g.received.is_some_and(|received| received != g.made)
            });
        if regeneration_differs
            || !o.mismatches.is_empty()
            || !o.tokens_identical
            || !o.decisions_identical
            || !o.input_disagreements.is_empty()
        {
            report.all_matched = false;
        }
        report.observers.insert(id.to_string(), o);
    }
    Ok(report)
}

/// True for an event camera's input channel (`/camera/<o>/input`).
fn is_input(topic: &str) -> bool {
    matches!(topic_key(topic), Some(proto::Key::CameraInput(_)))
}

fn replayer<'a>(
    replayers: &'a mut BTreeMap<ObserverId, Replayer>,
    id: &ObserverId,
    n: usize,
    modality: Modality,
    check: proto::FrameCheck,
    sessions: &BTreeMap<u64, Vec<SessionControl>>,
) -> Result<&'a mut Replayer> {
    if !replayers.contains_key(id) {
        // Session ticks recorded before this observer's first packet apply to it too.
        let mut r = Replayer::new(id.clone(), n, modality, check)?;
        for (tick, controls) in sessions {
            r.core.session(*tick, controls.clone());
        }
        replayers.insert(id.clone(), r);
    }
    Ok(replayers.get_mut(id).expect("inserted above"))
}

/// Compares the replay with the live decodes: wholly, or (`horizon`) what the ticks up to
/// `horizon` produced — the live streams must begin with exactly that.
fn compare(r: &Replayer, mut l: Live, horizon: Option<u64>) -> ObserverReplay {
    l.frames.sort_by_key(|f| f.seq);
    l.tokens.sort_by_key(|t| t.seq);
    let within = |tick: u64| horizon.is_none_or(|h| tick <= h);
    let frames: Vec<&FrameEvent> = r
        .frames
        .iter()
        .filter(|(t, _)| within(*t))
        .map(|(_, f)| f)
        .collect();
    let tokens: Vec<TokenEvent> = r
        .tokens
        .iter()
        .filter(|(t, _)| within(*t))
        .map(|(_, x)| x.clone())
        .collect();
    let decisions: Vec<Decision> = r
        .decisions
        .iter()
        .filter(|(t, _)| within(*t))
        .map(|(_, d)| d.clone())
        .collect();
    // A partial recording's live streams may go on past the horizon: compare their prefix.
    let cut = |n_live: usize, n_replay: usize| {
        if horizon.is_some() {
            n_live.min(n_replay)
        } else {
            n_live
        }
    };
    let live_frames = &l.frames[..cut(l.frames.len(), frames.len())];
    let live_tokens = &l.tokens[..cut(l.tokens.len(), tokens.len())];
    let live_decisions = &l.decisions[..cut(l.decisions.len(), decisions.len())];
    let mut out = ObserverReplay {
        payloads_live: live_frames.len(),
        payloads_replayed: frames.len(),
        tokens_live: live_tokens.len(),
        tokens_replayed: tokens.len(),
        tokens_identical: live_tokens == tokens.as_slice(),
        decisions_identical: live_decisions == decisions.as_slice(),
        ticks_replayed: horizon.map_or(r.core.next_tick(), |h| (h + 1).min(r.core.next_tick())),
        packets: r.packets_seen,
        events: r.events_seen,
        unassembled: r.unassembled,
        covered_through_tick: horizon,
        ..ObserverReplay::default()
    };
    let label = |f: Option<&FrameEvent>| {
        f.map_or("nothing".to_string(), |f| {
            format!(
                "{:06b} at {:.3} s",
                f.frame.payload,
                ns_s(f.frame.final_null_ns())
            )
        })
    };
    for i in 0..live_frames.len().max(frames.len()) {
        let (a, b) = (live_frames.get(i), frames.get(i).copied());
        match (a, b) {
            (Some(a), Some(b))
                if a.frame.payload == b.frame.payload
                    && a.frame.final_null_ns() == b.frame.final_null_ns() =>
            {
                out.payloads_matched += 1;
            }
            _ => out.mismatches.push(format!(
                "frame #{i}: live {}, replay {}",
                label(a),
                label(b)
            )),
        }
    }
    out.input_disagreements = l
        .inputs
        .iter()
        .filter(|(t, _)| within(**t))
        .filter(|(t, s)| r.inputs.get(t).is_some_and(|x| x != *s))
        .map(|(t, _)| *t)
        .collect();
    out
}

/// Prints the replay as text (`waggle replay` without `--json`).
pub fn print_replay(report: &ReplayReport) {
    if report.partial {
        println!(
            "partial recording ({}): each observer compared up to the last tick it covers",
            report.partial_reason.as_deref().unwrap_or("cut or damaged")
        );
    }
    for (o, r) in &report.observers {
        println!(
            "{o}: payloads matched {}/{} (replay released {}), tokens {}/{} {}, decisions {}, \
             {} packets, {} events, {} ticks",
            r.payloads_matched,
            r.payloads_live,
            r.payloads_replayed,
            r.tokens_replayed,
            r.tokens_live,
            if r.tokens_identical {
                "identical"
            } else {
                "DIFFER"
            },
            if r.decisions_identical {
                "identical"
            } else {
                "DIFFER"
            },
            r.packets,
            r.events,
            r.ticks_replayed
        );
        if let Some(g) = &r.regenerated {
            println!(
                "  packets regenerated from the recorded sensor input: {} ({} events), {}",
                g.made.packets,
                g.made.events,
                match g.received {
                    _ if g.unassembled > 0 => format!(
                        "{} inputs built on renders the recording lacks: NOT the packets received",
                        g.unassembled
                    ),
                    Some(received) if received == g.made => {
                        "bit for bit the packets the recorder received".to_string()
                    }
                    Some(received) => format!(
                        "DIFFER from the {} packets ({} events) the recorder received",
                        received.packets, received.events
                    ),
                    None => "the recording holds no account of the packets received".to_string(),
                }
            );
        }
        if let Some(t) = r.covered_through_tick {
            println!(
                "  compared through tick {t} (sim {:.2} s)",
                ns_s(t * TICK_NS)
            );
        }
        for m in &r.mismatches {
            println!("  ✗ {m}");
        }
        if !r.input_disagreements.is_empty() {
            println!(
                "  ✗ input state differs from the live status at ticks {:?}",
                r.input_disagreements
            );
        }
    }
    println!(
        "{}",
        if report.all_matched {
            "replay reproduces every live decode"
        } else {
            "MISMATCH"
        }
    );
}
