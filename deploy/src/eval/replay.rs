//! `waggle replay DIR/session.mcap [--json]`: the event receivers re-run from a recording.
//!
//! Loads no MuJoCo scene and no RGB image. For each observer it feeds a fresh
//! [`ObserverRuntime`] — the very code path `observer-node` runs — with that observer's
//! recorded raw event packets and the recorded session controls (reception windows, round
//! resets, mission end), tick by tick in the observer process's order: the controls of tick
//! k−1, then packet k, or "missing" when the recording holds no packet k (a later packet of that
//! camera exists, or the recording ends). It then compares every released payload and final-NULL
//! time — and, more strictly, every token, decision and per-tick input state — with the live
//! decodes recorded on `observer/Oi/{frames,tokens,decision,status}`. Any mismatch fails.

use std::collections::BTreeMap;

use anyhow::{Context, Result, bail};
use perception::perception::Modality;
use perception::runtime::ObserverRuntime;
use perception::tick::{MissingReason, Step, TickAssembler};
use proto::{
    Decision, EventPacket, FrameEvent, InputState, ObserverId, Roster, SessionControl, TokenEvent,
};
use recording::Decoded;
use serde::Serialize;

use crate::eval::recording::{resolve, scan, topic_observer};
use crate::eval::summary::ns_s;

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
}

/// What `waggle replay --json` prints.
#[derive(Debug, Clone, Serialize)]
pub struct ReplayReport {
    pub partial: bool,
    pub observers: BTreeMap<String, ObserverReplay>,
    pub all_matched: bool,
}

/// One observer's receiver driven exactly as `observer-node`'s main loop drives it: the
/// shared tick assembler ([`TickAssembler`]) orders the recorded session controls and event
/// packets, the recording's clock is its watermark, and its end judges a packet missing.
struct Replayer {
    runtime: ObserverRuntime,
    assembler: TickAssembler,
    done: bool,
    tokens: Vec<TokenEvent>,
    frames: Vec<FrameEvent>,
    decisions: Vec<Decision>,
    inputs: BTreeMap<u64, InputState>,
    packets_seen: u64,
    events_seen: u64,
}

impl Replayer {
    fn new(id: ObserverId, observers: usize) -> Result<Self> {
        Ok(Self {
            runtime: ObserverRuntime::new(id, Roster::default_scene(observers), Modality::Events)
                .context("building the event receiver")?,
            assembler: TickAssembler::new(),
            done: false,
            tokens: Vec::new(),
            frames: Vec::new(),
            decisions: Vec::new(),
            inputs: BTreeMap::new(),
            packets_seen: 0,
            events_seen: 0,
        })
    }

    fn packet(&mut self, p: EventPacket) {
        self.packets_seen += 1;
        self.events_seen += p.len() as u64;
        self.assembler.packet(p);
    }

    /// Advances as far as the recording read so far allows (`last_clock`: the latest recorded
    /// clock tick; `eof`: nothing more will come).
    fn advance(&mut self, last_clock: Option<u64>, eof: bool) -> Result<()> {
        if let Some(c) = last_clock {
            self.assembler.clocks_through(c);
        }
        let judge = |_tick| eof.then_some(MissingReason::EndOfRecording);
        while !self.done {
            let Some(step) = self.assembler.next_step(judge) else {
                // Waiting for session controls or a clock the recording does not hold.
                self.done = eof;
                return Ok(());
            };
            match step {
                Step::Session { controls, .. } => {
                    self.runtime.apply_session(&controls);
                    self.done = self.runtime.ended();
                }
                Step::Tick { tick, input } => {
                    let report = self
                        .runtime
                        .step(tick, input.data())
                        .with_context(|| format!("replaying tick {tick}"))?;
                    self.tokens.extend(report.tokens);
                    self.frames.extend(report.frames);
                    self.decisions.extend(report.decision);
                    self.inputs.insert(tick, report.status.input);
                }
            }
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

/// Replays the recording at `path` and compares with its live decodes.
pub fn replay_recording(path: &std::path::Path) -> Result<ReplayReport> {
    let mut replayers: BTreeMap<ObserverId, Replayer> = BTreeMap::new();
    let mut live: BTreeMap<ObserverId, Live> = BTreeMap::new();
    let mut observers: Option<usize> = None;
    let mut modality: Option<String> = None;
    let mut sessions_all: BTreeMap<u64, Vec<SessionControl>> = BTreeMap::new();
    let mut last_clock: Option<u64> = None;
    let mut rgb_frames = 0u64;
    let info = recording::leading_metadata(&resolve(path), recording::SESSION_METADATA)?
        .map(|m| recording::SessionInfo::from_metadata(&m));
    if let Some(info) = info {
        observers = Some(info.observers).filter(|n| *n > 0);
        modality = info.modality;
    }
    if modality.as_deref() == Some("rgb") {
        bail!(
            "replay needs raw event packets: this recording is of an RGB session (modality rgb); \
             the event receivers cannot be replayed from it"
        );
    }
    let n = observers.unwrap_or(proto::scene::MAX_OBSERVERS);
    let scanned = scan(path, |item| {
        match item.msg {
            Decoded::Clock(c) => last_clock = last_clock.max(Some(c.tick)),
            Decoded::SessionTick(s) => {
                for r in replayers.values_mut() {
                    r.assembler.session(s.tick, s.controls.clone());
                }
                sessions_all.insert(s.tick, s.controls);
            }
            Decoded::EventPacket(p) => {
                let o = topic_observer(item.topic)
                    .with_context(|| format!("no observer in topic {}", item.topic))?;
                let r = replayer(&mut replayers, &o, n, &sessions_all)?;
                r.packet(p);
            }
            Decoded::RgbFrame(_) => rgb_frames += 1,
            Decoded::FrameEvent(f) => live.entry(f.observer.clone()).or_default().frames.push(f),
            Decoded::TokenEvent(t) => live.entry(t.observer.clone()).or_default().tokens.push(t),
            Decoded::Decision(d) => live
                .entry(d.observer.clone())
                .or_default()
                .decisions
                .push(d),
            Decoded::ObserverStatus(s) => {
                live.entry(s.observer.clone())
                    .or_default()
                    .inputs
                    .insert(s.tick, s.input);
            }
            _ => {}
        }
        for r in replayers.values_mut() {
            r.advance(last_clock, false)?;
        }
        Ok(())
    })?;
    if replayers.is_empty() {
        if rgb_frames > 0 {
            bail!(
                "replay needs raw event packets: this recording holds RGB frames only (an RGB \
                 session); the event receivers cannot be replayed from it"
            );
        }
        bail!("the recording holds no event packets: nothing to replay");
    }
    let mut report = ReplayReport {
        partial: !scanned.outcome.complete,
        observers: BTreeMap::new(),
        all_matched: true,
    };
    for (id, r) in &mut replayers {
        r.advance(last_clock, true)?;
        let l = live.remove(id).unwrap_or_default();
        let o = compare(r, l);
        if !o.mismatches.is_empty()
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

fn replayer<'a>(
    replayers: &'a mut BTreeMap<ObserverId, Replayer>,
    id: &ObserverId,
    n: usize,
    sessions: &BTreeMap<u64, Vec<SessionControl>>,
) -> Result<&'a mut Replayer> {
    if !replayers.contains_key(id) {
        // Session ticks recorded before this observer's first packet apply to it too.
        let mut r = Replayer::new(id.clone(), n)?;
        for (tick, controls) in sessions {
            r.assembler.session(*tick, controls.clone());
        }
        replayers.insert(id.clone(), r);
    }
    Ok(replayers.get_mut(id).expect("inserted above"))
}

fn compare(r: &Replayer, mut l: Live) -> ObserverReplay {
    l.frames.sort_by_key(|f| f.seq);
    l.tokens.sort_by_key(|t| t.seq);
    let mut out = ObserverReplay {
        payloads_live: l.frames.len(),
        payloads_replayed: r.frames.len(),
        tokens_live: l.tokens.len(),
        tokens_replayed: r.tokens.len(),
        tokens_identical: l.tokens == r.tokens,
        decisions_identical: l.decisions == r.decisions,
        ticks_replayed: r.assembler.next_tick(),
        packets: r.packets_seen,
        events: r.events_seen,
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
    for i in 0..l.frames.len().max(r.frames.len()) {
        let (a, b) = (l.frames.get(i), r.frames.get(i));
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
        .filter(|(t, s)| r.inputs.get(t).is_some_and(|x| x != *s))
        .map(|(t, _)| *t)
        .collect();
    out
}

/// Prints the replay as text (`waggle replay` without `--json`).
pub fn print_replay(report: &ReplayReport) {
    if report.partial {
        println!("(partial recording: replayed what could be read)");
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
