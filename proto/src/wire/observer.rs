//! What an observer publishes: tokens, released frames, decisions and per-tick status.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::codec::Validate;
use crate::frame::ReleasedFrame;
use crate::keys::ObserverId;
use crate::payload::{Offer, Site};
use crate::token::Token;

/// One confirmed token (`observer/<o>/tokens`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct TokenEvent {
    pub observer: ObserverId,
    /// Sequence number in this observer's token stream, contiguous from 0.
    pub seq: u64,
    pub token: Token,
    /// Sim time at which the token was confirmed.
    pub confirmed_ns: u64,
}

impl Validate for TokenEvent {
    fn validate(&self) -> Result<(), String> {
        Ok(())
    }
}

/// One released frame (`observer/<o>/frames`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct FrameEvent {
    pub observer: ObserverId,
    /// Sequence number in this observer's frame stream, contiguous from 0.
    pub seq: u64,
    /// The round whose reception window was open when the frame was released.
    pub round: u32,
    pub frame: ReleasedFrame,
}

impl Validate for FrameEvent {
    fn validate(&self) -> Result<(), String> {
        self.frame
            .check()
            .map_err(|e| format!("frame {} of {}: {e}", self.seq, self.observer))
    }
}

/// A frame a decision was computed from.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SourceFrame {
    /// Observer whose frame stream released the frame (the audit requires the decider).
    pub observer: ObserverId,
    pub frame_seq: u64,
    pub offer: Offer,
    pub final_null_ns: u64,
}

/// An observer's allocation for one round (`observer/<o>/decision`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Decision {
    pub observer: ObserverId,
    pub round: u32,
    /// Sim time of the decision.
    pub decided_ns: u64,
    /// This observer's own assignment (`None` = stay home).
    pub assignment: Option<Site>,
    /// The frames the decision used, one per site.
    pub sources: Vec<SourceFrame>,
    /// The whole allocation as this observer computed it.
    pub allocation: BTreeMap<ObserverId, Option<Site>>,
}

impl Validate for Decision {
    fn validate(&self) -> Result<(), String> {
        let mut sites = std::collections::BTreeSet::new();
        for s in &self.sources {
            s.offer.check().map_err(|e| e.to_string())?;
            if !sites.insert(s.offer.site) {
                return Err(format!(
                    "decision of {} has two source frames for {}",
                    self.observer, s.offer.site
                ));
            }
        }
        if self
            .allocation
            .get(&self.observer)
            .is_some_and(|a| *a != self.assignment)
        {
            return Err(format!(
                "decision of {} assigns {:?} but its allocation says {:?}",
                self.observer, self.assignment, self.allocation[&self.observer]
            ));
        }
        Ok(())
    }
}

/// How the observer's input stood for one tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum InputState {
    /// The tick's sensor packet arrived and was valid.
    Received,
    /// The packet arrived flagged invalid.
    Invalid,
    /// The packet was judged missing (later seq, dead camera, or grace period).
    Missing,
}

/// What the observer is doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ObserverPhase {
    /// No reception window is open.
    Idle,
    /// Receiving and parsing; no decision yet in this round.
    Receiving,
    /// Decided in this round.
    Decided,
    /// The mission has ended.
    Ended,
}

/// Per-tick heartbeat of an observer (`observer/<o>/status`); closes tick `tick` in the lockstep.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ObserverStatus {
    pub observer: ObserverId,
    pub tick: u64,
    pub round: u32,
    pub phase: ObserverPhase,
    pub input: InputState,
    /// Tokens of the incomplete frame currently held (0–16).
    pub parser_progress: u8,
    /// Tokens confirmed so far in the mission.
    pub tokens: u64,
    /// Frames released so far in the mission.
    pub frames: u64,
    /// Assignment of the current round, once decided.
    pub assignment: Option<Site>,
    /// The decision made in this very tick, if any (also published on `observer/<o>/decision`).
    /// The scheduler takes decisions from here: status{k} is the one message it waits for, so
    /// no decision can arrive after the tick it belongs to.
    pub decision: Option<Decision>,
}

impl Validate for ObserverStatus {
    fn validate(&self) -> Result<(), String> {
        if usize::from(self.parser_progress) >= crate::frame::MAX_FRAME_TOKENS {
            return Err(format!(
                "parser progress {} beyond the longest frame ({} tokens)",
                self.parser_progress,
                crate::frame::MAX_FRAME_TOKENS
            ));
        }
        if let Some(d) = &self.decision {
            d.validate()?;
            if d.observer != self.observer {
                return Err(format!(
                    "status of {} carries a decision of {}",
                    self.observer, d.observer
                ));
            }
        }
        Ok(())
    }
}
