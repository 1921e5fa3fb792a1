//! Typed views of the flight terms: the wind (`wind.*`) and the realistic controller
//! (`flight.cascade`, `flight.estimate_*`). Plain numbers with units; the physics (`sim::wind`,
//! `sim::cascade`) turns them into processes. Both are off by default, and either one on makes a
//! trial fly its own flight ([`Perturbation::reflies`]).

use crate::seed::{Stream, stream_seed};
use crate::spec::Perturbation;

/// The wind terms (`sim::wind::WindConfig::from_terms` takes them as they are).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindTerms {
    /// Mean horizontal wind speed, m/s.
    pub mean_mps: f64,
    /// Direction the mean wind blows towards, degrees anticlockwise from world +x.
    pub direction_deg: f64,
    /// Dryden horizontal turbulence σ (σ_u = σ_v), m/s; 0 = steady wind.
    pub sigma_mps: f64,
    /// Dryden length scale L_u = L_v, m; 0 = the MIL-HDBK-1797 low-altitude form's own.
    pub length_m: f64,
    /// Seed of the turbulence.
    pub seed: u64,
}

/// The cascade controller's estimate terms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CascadeTerms {
    /// σ of each axis of the position estimate's error, m.
    pub estimate_sigma_m: f64,
    /// Age of the estimate, ns.
    pub estimate_latency_ns: u64,
    /// Seed of the estimate noise.
    pub seed: u64,
}

impl Perturbation {
    /// The wind of trial `trial_seed`, or `None` when there is none (no mean, no turbulence).
    pub fn wind_of(&self, trial_seed: u64) -> Option<WindTerms> {
        let mean_mps = self.get("wind.mean_mps");
        let sigma_mps = self.get("wind.sigma_mps") + self.get("wind.intensity") * mean_mps;
        (mean_mps > 0.0 || sigma_mps > 0.0).then(|| WindTerms {
            mean_mps,
            direction_deg: self.get("wind.direction_deg"),
            sigma_mps,
            length_m: self.get("wind.length_m"),
            seed: stream_seed(trial_seed, Stream::Wind, 0),
        })
    }

    /// The wind terms with seed 0, `None` when there is no wind ([`Perturbation::wind_of`] seeds
    /// them for a trial).
    pub fn wind(&self) -> Option<WindTerms> {
        self.wind_of(0)
    }

    /// The cascade's terms for trial `trial_seed`, or `None` under the ideal controller.
    pub fn cascade_of(&self, trial_seed: u64) -> Option<CascadeTerms> {
        (self.get("flight.cascade") != 0.0).then(|| CascadeTerms {
            estimate_sigma_m: self.get("flight.estimate_sigma_m"),
            estimate_latency_ns: (self.get("flight.estimate_latency_ms") * 1e6).round() as u64,
            seed: stream_seed(trial_seed, Stream::Estimate, 0),
        })
    }

    /// The cascade's terms with seed 0 (`None` under the ideal controller).
    pub fn cascade(&self) -> Option<CascadeTerms> {
        self.cascade_of(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wind_and_cascade_are_off_by_default_and_refly_when_on() {
        let none = Perturbation::default();
        assert!(none.wind().is_none() && none.cascade().is_none() && !none.reflies());
        let mut p = Perturbation::parse(&["wind.direction_deg=90", "wind.length_m=10"]).unwrap();
        assert!(
            p.wind().is_none() && !p.reflies(),
            "direction alone is no wind"
        );
        p.set("wind.sigma_mps", 0.5).unwrap();
        let w = p.wind_of(7).unwrap();
        assert_eq!((w.mean_mps, w.direction_deg, w.sigma_mps), (0.0, 90.0, 0.5));
        assert_eq!(w.seed, stream_seed(7, Stream::Wind, 0));
        assert!(p.reflies());
        let c = Perturbation::parse(&["flight.cascade=1"]).unwrap();
        let t = c.cascade_of(3).unwrap();
        assert_eq!(
            (t.estimate_sigma_m, t.estimate_latency_ns),
            (0.02, 4_000_000)
        );
        assert!(c.reflies());
        assert!(Perturbation::parse(&["flight.cascade=0.5"]).is_err());
    }

    #[test]
    fn turbulence_intensity_scales_the_gusts_with_the_mean_wind() {
        let p = Perturbation::parse(&["wind.intensity=0.25"]).unwrap();
        assert!(
            p.wind().is_none(),
            "intensity without a mean wind is still air"
        );
        let p = Perturbation::parse(&["wind.intensity=0.25", "wind.mean_mps=2"]).unwrap();
        assert_eq!(p.wind().unwrap().sigma_mps, 0.5);
        let p = Perturbation::parse(&[
            "wind.intensity=0.25",
            "wind.mean_mps=2",
            "wind.sigma_mps=0.1",
        ])
        .unwrap();
        assert!((p.wind().unwrap().sigma_mps - 0.6).abs() < 1e-12);
        assert!(Perturbation::parse(&["wind.intensity=1.5"]).is_err());
    }
}
