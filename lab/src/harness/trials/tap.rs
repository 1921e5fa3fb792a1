//! A trial's sensor inputs handed out one at a time, for a receiver that lives outside the lab
//! (the Python package): exactly what trial `index` gives Waggle's receivers — the same flight
//! (the trial's own when the perturbation re-flies it), the same sensor, noise and link draws —
//! with the performer's image position and the airframe's turn beside each input. The flight
//! streams, keeping nothing; a consumer that stops reading stops it.

use std::sync::atomic::AtomicBool;
use std::sync::mpsc::SyncSender;

use anyhow::{Result, bail};
use perturb::seed::trial_seed;
use proto::Schedule;

use crate::harness::flight::rendered::{FlightSpec, Flown};
use crate::harness::trials::TrialsOptions;
use crate::harness::trials::observer::{TapClosed, Tapped, observe_flying};

impl TrialsOptions {
    /// The flight trial `index` sees: the condition's shared one, or its own when the
    /// perturbation re-flies every trial.
    pub fn trial_flight_spec(&self, index: u64) -> Result<FlightSpec> {
        if self.perturbation.reflies() {
            self.flight_spec(Some(trial_seed(self.seed, index)))
        } else {
            self.flight_spec(None)
        }
    }

    /// The broadcast trial `index` flies: its labelled timeline and offers.
    pub fn trial_schedule(&self, index: u64) -> Result<Schedule> {
        Ok(self.trial_flight_spec(index)?.schedule)
    }
}

/// Flies trial `index` of `opts` and sends every observer's inputs to `sender`, in the order
/// its receiver would get them. `None` when the consumer went away before the flight ended;
/// else what the flight gave (the ideal receiver's decodes among it).
pub fn tap_trial(
    opts: &TrialsOptions,
    index: u64,
    sender: &SyncSender<Tapped>,
) -> Result<Option<Flown>> {
    opts.check()?;
    if index >= opts.trials {
        bail!("trial {index} is outside 0..{}", opts.trials);
    }
    let spec = opts.trial_flight_spec(index)?;
    let mut sensing = opts.sensing(None);
    sensing.tap = Some(sender);
    let stop = AtomicBool::new(false);
    match observe_flying(&spec, &sensing, trial_seed(opts.seed, index), &stop) {
        Err(e) if e.downcast_ref::<TapClosed>().is_some() => Ok(None),
        Err(e) => Err(e),
        Ok(observed) => Ok(observed.map(|(flown, _)| flown)),
    }
}
