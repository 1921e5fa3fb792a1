//! Real air for a flown trial: the perturbation's wind (`wind.*`: MuJoCo-side Dryden turbulence
//! and Crazyflie rotor drag, `sim::wind`) and the Crazyflie-like cascade controller
//! (`flight.cascade`, `flight.estimate_*`: `sim::cascade`) set on a freshly built world, both
//! seeded from the trial's seed. Neither term given: the world is left exactly as built (the
//! paper's still air and ideal stabilisation).

use anyhow::{Context, Result};
use perturb::Perturbation;
use serde::{Deserialize, Serialize};
use sim::cascade::CascadeConfig;
use sim::wind::WindConfig;
use sim::world::{ControllerKind, DroneIndex, World};

/// Sets `p`'s wind and controller on `world` for the trial seeded `seed`; true when either was
/// set (the flight then differs from the paper's).
pub fn set_air(world: &mut World, p: &Perturbation, seed: u64) -> Result<bool> {
    let wind = p.wind_of(seed);
    if let Some(w) = &wind {
        let config =
            WindConfig::from_terms(w.mean_mps, w.direction_deg, w.sigma_mps, w.length_m, w.seed);
        world.set_wind(Some(config)).context("the wind terms")?;
    }
    let cascade = p.cascade_of(seed);
    if let Some(c) = &cascade {
        let config = CascadeConfig::from_terms(c.estimate_sigma_m, c.estimate_latency_ns, c.seed);
        world.set_controller(ControllerKind::Cascade(config));
    }
    Ok(wind.is_some() || cascade.is_some())
}

pub use run_format::trial_record::Tracking;

/// Drone `i`'s tracking so far.
pub fn tracking_of(world: &World, i: DroneIndex) -> Tracking {
    let t = world.tracking_error(i);
    Tracking {
        rms_m: t.rms_m,
        max_m: t.max_m,
    }
}

/// The performer's tracking over a set of trials (a study point's).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub struct PointTracking {
    /// Mean over the trials of each flight's RMS error, m.
    pub mean_rms_m: f64,
    /// Largest error of any trial, m.
    pub max_m: f64,
    /// Trials with a contact between drones.
    pub contact_trials: u64,
}

impl PointTracking {
    /// Pools `parts` (each with its trial count); `None` when there is none.
    pub fn pooled(parts: impl Iterator<Item = (u64, PointTracking)>) -> Option<Self> {
        let (mut n, mut sum, mut max_m, mut contact_trials) = (0u64, 0.0, 0.0f64, 0);
        for (trials, t) in parts {
            n += trials;
            sum += t.mean_rms_m * trials as f64;
            max_m = max_m.max(t.max_m);
            contact_trials += t.contact_trials;
        }
        (n > 0).then(|| Self {
            mean_rms_m: sum / n as f64,
            max_m,
            contact_trials,
        })
    }

    /// The report's cells: `mean RMS / max` in mm, and the trials with contact.
    pub fn cells(tracking: Option<&Self>) -> String {
        tracking.map_or("— | —".to_owned(), |t| {
            format!(
                "{:.1} / {:.1} | {}",
                t.mean_rms_m * 1e3,
                t.max_m * 1e3,
                t.contact_trials
            )
        })
    }
}
