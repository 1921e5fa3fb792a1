//! A round's broadcast as the performer will fly it: the offers, the acquisition preamble and
//! the performer's own deterministic schedule, fixed when the broadcast starts.

use proto::sched::Broadcast;
use proto::{Offer, ScheduledOffer};

use crate::config::SchedulerConfig;
use crate::error::SchedulerError;

/// A broadcast the performer must fly, starting at `start_ns` (= the sim time of the tick that
/// emitted it).
#[derive(Debug, Clone, PartialEq)]
pub struct BroadcastPlan {
    pub round: u32,
    /// In transmission order (A then B in the paper).
    pub offers: Vec<Offer>,
    /// Events modality: the acquisition sweep and its quiet precede the first offer.
    pub acquisition: bool,
    pub start_ns: u64,
    /// When the performer's schedule ends (end of the last final NULL hold).
    pub end_ns: u64,
    /// Per offer: payload, start and final-NULL start, exactly as the performer will fly them.
    pub scheduled: Vec<ScheduledOffer>,
}

impl BroadcastPlan {
    /// The broadcast of `offers` for round `round`, starting at `start_ns`. Its end comes
    /// from the schedule the performer derives from the same inputs, so the reception window
    /// the scheduler times from it matches what is actually flown.
    pub(super) fn plan(
        round: u32,
        offers: &[Offer],
        start_ns: u64,
        config: &SchedulerConfig,
    ) -> Result<Self, SchedulerError> {
        let payloads: Vec<u8> = offers.iter().map(Offer::to_payload).collect();
        let acquisition = config.modality.acquisition();
        let schedule = proto::broadcast(
            start_ns,
            &payloads,
            acquisition,
            &config.gesture,
            config.frame_check,
        )?;
        Ok(Self {
            round,
            offers: offers.to_vec(),
            acquisition,
            start_ns,
            end_ns: schedule.end_ns(),
            scheduled: schedule.offers().to_vec(),
        })
    }

    /// The wire form for `sched/broadcast` (`start_ns` is the sim time of `tick`).
    pub fn to_proto(&self, tick: u64) -> Broadcast {
        Broadcast {
            tick,
            round: self.round,
            start_ns: self.start_ns,
            offers: self.offers.clone(),
            acquisition: self.acquisition,
        }
    }
}
