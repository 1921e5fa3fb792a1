//! How a whole mission is flown beyond its case (`waggle mission`, `--case` trials): the
//! allocation policy, the perturbation and its seed, plug-in receivers, and which
//! perturbations a whole mission refuses.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use anyhow::{Result, bail};
use perturb::Perturbation;
use proto::RenderPath;

use commands::Policy;
use receiver_plugin::ObserverPlugin;

/// How a mission is flown beyond its case: allocation policy, perturbation and its seed.
#[derive(Debug, Clone, Default)]
pub struct MissionOptions {
    pub render: RenderPath,
    pub policy: Policy,
    pub perturbation: Perturbation,
    pub seed: u64,
    /// Raised to abandon the mission (Ctrl-C during trials): checked every tick.
    pub stop: Option<Arc<AtomicBool>>,
    /// Observers whose receiver is a plug-in (`--receiver O2=python:MODULE:CLASS`).
    pub receivers: Vec<ObserverPlugin>,
    /// The wall-clock time a plug-in may take over the whole mission (`None`: no limit).
    pub plugin_time_limit: Option<Duration>,
}

impl MissionOptions {
    /// Refuses perturbation terms a whole mission does not model (yet), naming them.
    pub fn check(&self) -> Result<()> {
        self.perturbation.check()?;
        for key in [
            "geometry.position_sigma_m",
            "geometry.yaw_sigma_deg",
            "link.delay_ms",
            "rgb.blur_renders",
        ] {
            if self.perturbation.non_default().contains_key(key) {
                bail!(
                    "{key} is modelled in link trials (--link) only, not in whole missions: \
                     placement jitter would move the scheduler's homes, a delay the lockstep, and \
                     blur needs 100 Hz renders of RGB cameras"
                );
            }
        }
        if self.perturbation.rgb().blur_renders > 1 {
            bail!(
                "light.lux = {} lx needs a {} ms RGB exposure (motion blur), modelled in link \
                 trials (--link) only, not in whole missions: blur needs 100 Hz renders of RGB \
                 cameras",
                self.perturbation.lux(),
                10 * self.perturbation.rgb().blur_renders
            );
        }
        Ok(())
    }
}
