//! What terms mean together: the checks that no single term's range can make, run once every
//! term of a [`Perturbation`] is set.

use crate::error::PerturbError;
use crate::spec::{Perturbation, parameter};

impl Perturbation {
    /// Checks what terms mean together once every one is set (each alone is checked by
    /// [`Perturbation::set`]): under a modelled light level the event sensor's shot noise is
    /// its own plus darkness's ([`crate::light::event_shot_noise_hz`]), and that sum must stay
    /// within `events.shot_noise_hz`'s own range — a light level of 0.001 lx alone would ask
    /// for ≈ 850 Hz per pixel, an hour of events per trial.
    pub fn check(&self) -> Result<(), PerturbError> {
        let lux = self.lux();
        if lux <= 0.0 {
            return Ok(());
        }
        let own_hz = self.get("events.shot_noise_hz");
        let shot_hz = self.event_shot_noise_hz();
        let max_hz = parameter("events.shot_noise_hz").map_or(f64::INFINITY, |p| p.max);
        if shot_hz <= max_hz {
            return Ok(());
        }
        let dim_hz_lx = self.get("light.dim_shot_hz_lx");
        let least = if own_hz < max_hz {
            format!(
                ": at least {:.3} lx with this events.shot_noise_hz",
                dim_hz_lx / (max_hz - own_hz)
            )
        } else {
            String::new()
        };
        Err(PerturbError::TooDark {
            lux,
            own_hz,
            shot_hz,
            dim_hz_lx,
            max_hz,
            least,
        })
    }
}
