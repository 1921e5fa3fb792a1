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
use proto::Receiver;
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
    /// Keep every event each observer's camera produced, before the sensor link's loss
    /// (`waggle mission --events-raw`), in [`super::MissionRun::events`].
    pub keep_events: bool,
}

impl MissionOptions {
    /// Refuses perturbation terms a whole mission on `modality`'s cameras does not model (yet),
    /// naming them. Light needing an RGB exposure longer than a frame's render is refused only
    /// when the observers fly RGB cameras: event cameras take every light level.
    pub fn check(&self, modality: Receiver) -> Result<()> {
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
        if modality == Receiver::Rgb && self.perturbation.rgb().blur_renders > 1 {
            bail!(
                "light.lux = {} lx needs a {} ms RGB exposure (motion blur), modelled in link \
                 trials (--link) only, not in whole missions with RGB cameras: blur needs 100 Hz \
                 renders of RGB cameras (event cameras take this light level in missions)",
                self.perturbation.lux(),
                10 * self.perturbation.rgb().blur_renders
            );
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn under(terms: &[&str]) -> MissionOptions {
        MissionOptions {
            perturbation: Perturbation::parse(terms).unwrap(),
            ..MissionOptions::default()
        }
    }

    #[test]
    fn dim_light_is_refused_only_for_rgb_cameras() {
        let dim = under(&["light.lux=5"]);
        let why = dim.check(Receiver::Rgb).unwrap_err().to_string();
        assert!(why.contains("light.lux = 5 lx"), "{why}");
        dim.check(Receiver::Events).unwrap();
        dim.check(Receiver::Ideal).unwrap();
        under(&["light.lux=3000"]).check(Receiver::Rgb).unwrap();
    }

    #[test]
    fn link_only_terms_are_refused_for_every_camera() {
        for receiver in [Receiver::Ideal, Receiver::Rgb, Receiver::Events] {
            let why = under(&["geometry.yaw_sigma_deg=2"])
                .check(receiver)
                .unwrap_err()
                .to_string();
            assert!(why.starts_with("geometry.yaw_sigma_deg"), "{why}");
        }
    }
}
