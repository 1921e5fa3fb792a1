//! The set of perturbation values a trial runs with, checked against the table of terms
//! ([`crate::parameters`]), and the typed views the sensors and flight read from it.
//!
//! A term is written `group.name=value` (`--perturb events.shot_noise_hz=0.5`, a study file's
//! level); every default means "off", so an empty [`Perturbation`] is today's noiseless run.

use std::collections::BTreeMap;

use std::sync::Arc;

use event_camera::real_noise::RealNoise;
use event_camera::{EventNoise, EventSensorModel};

use crate::error::PerturbError;
use crate::link::LinkNoise;
pub use crate::parameters::{PARAMETERS, Parameter};
use crate::rgb::RgbNoise;

/// The entry of `table` whose name (`name_of`) is `name`, or every name, comma-separated, for
/// the error that refuses it.
pub(crate) fn find_named<T>(
    table: &'static [T],
    name: &str,
    name_of: fn(&T) -> &'static str,
) -> Result<&'static T, String> {
    table
        .iter()
        .find(|t| name_of(t) == name)
        .ok_or_else(|| table.iter().map(name_of).collect::<Vec<_>>().join(", "))
}

/// The parameter named `key`.
pub fn parameter(key: &str) -> Result<&'static Parameter, PerturbError> {
    find_named(PARAMETERS, key, |p| p.key).map_err(|known| PerturbError::UnknownKey {
        key: key.to_owned(),
        known,
    })
}

/// The values a trial runs with: every term not set is at its default (off).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Perturbation {
    set: BTreeMap<&'static str, f64>,
    /// A real recording's background for the event sensor (`crate::real`).
    pub(crate) real_noise: Option<Arc<RealNoise>>,
}

impl Perturbation {
    /// Sets `key` to `value`, checking the name and the range.
    pub fn set(&mut self, key: &str, value: f64) -> Result<(), PerturbError> {
        let p = parameter(key)?;
        let whole_ok = !p.integer || value.fract() == 0.0;
        if !(value.is_finite() && value >= p.min && value <= p.max && whole_ok) {
            return Err(PerturbError::OutOfRange {
                key: key.to_owned(),
                value,
                min: p.min,
                max: p.max,
                unit: p.unit,
                whole: if p.integer { ", a whole number" } else { "" },
            });
        }
        if value == p.default {
            self.set.remove(p.key);
        } else {
            self.set.insert(p.key, value);
        }
        Ok(())
    }

    /// Applies one `KEY=VALUE` assignment.
    pub fn assign(&mut self, assignment: &str) -> Result<(), PerturbError> {
        let (key, value) = assignment
            .split_once('=')
            .ok_or_else(|| PerturbError::NotAnAssignment(assignment.to_owned()))?;
        let (key, value) = (key.trim(), value.trim());
        parameter(key)?;
        let v: f64 = value.parse().map_err(|_| PerturbError::NotANumber {
            key: key.to_owned(),
            value: value.to_owned(),
        })?;
        self.set(key, v)
    }

    /// The perturbation of `assignments` (`KEY=VALUE` each).
    pub fn parse<S: AsRef<str>>(assignments: &[S]) -> Result<Self, PerturbError> {
        let mut p = Self::default();
        for a in assignments {
            p.assign(a.as_ref())?;
        }
        p.check()?;
        Ok(p)
    }

    /// The value of `key` (its default when not set; NaN for a key not in the table).
    pub fn get(&self, key: &str) -> f64 {
        match self.set.get(key) {
            Some(&v) => v,
            None => parameter(key).map_or(f64::NAN, |p| p.default),
        }
    }

    /// The terms that differ from their defaults, sorted by key (what `trials.json` records).
    pub fn non_default(&self) -> &BTreeMap<&'static str, f64> {
        &self.set
    }

    /// The terms that differ from their defaults, as owned keys (what a results file records).
    pub fn recorded(&self) -> BTreeMap<String, f64> {
        self.set
            .iter()
            .map(|(k, v)| ((*k).to_owned(), *v))
            .collect()
    }

    /// True when nothing is perturbed.
    pub fn is_none(&self) -> bool {
        self.set.is_empty() && self.real_noise.is_none()
    }

    /// True when a trial must fly its own flight (placement, gusts, wind or the cascade with its
    /// seeded estimate), not share one.
    pub fn reflies(&self) -> bool {
        self.placement_sigma() != (0.0, 0.0)
            || self.gust_sigma_n() > 0.0
            || self.wind().is_some()
            || self.cascade().is_some()
    }

    /// The event sensor (threshold and noise), its noise seeded with `seed`.
    pub fn event_sensor(&self, seed: u64) -> EventSensorModel {
        EventSensorModel {
            threshold: self.get("events.threshold"),
            noise: self.event_noise(seed),
        }
    }

    /// The event sensor's noise terms, seeded with `seed`.
    pub fn event_noise(&self, seed: u64) -> EventNoise {
        let hot_pixels = self.get("events.hot_pixels") as u32;
        let mut noise = EventNoise {
            threshold_sigma: self.get("events.threshold_sigma"),
            refractory_ns: (self.get("events.refractory_ms") * 1e6).round() as u64,
            leak_hz: self.get("events.leak_hz"),
            leak_spread_decades: self.get("events.leak_spread_decades"),
            leak_jitter: self.get("events.leak_jitter"),
            shot_noise_hz: self.event_shot_noise_hz(),
            shot_noise_bright_drop: self.get("events.shot_noise_bright_drop"),
            cutoff_hz: self.event_cutoff_hz(),
            linlog_dn: self.get("events.linlog_dn"),
            hot_pixels,
            hot_pixel_hz: if hot_pixels > 0 {
                self.get("events.hot_pixel_hz")
            } else {
                0.0
            },
            seed,
        };
        self.add_fitted_real_noise(&mut noise);
        noise
    }

    /// Scene illuminance, lx (0: not modelled).
    pub fn lux(&self) -> f64 {
        self.get("light.lux")
    }

    /// The event sensor's cutoff: its own, or under a modelled light level its own (or v2e's
    /// default) at office light scaled by the light ([`crate::light`]).
    fn event_cutoff_hz(&self) -> f64 {
        let own = self.get("events.cutoff_hz");
        match self.lux() {
            lux if lux > 0.0 => {
                crate::light::event_cutoff_hz(lux, own, self.get("light.cutoff_scale"))
            }
            _ => own,
        }
    }

    /// The event sensor's shot noise: its own, plus darkness's under a modelled light level.
    pub(crate) fn event_shot_noise_hz(&self) -> f64 {
        let own = self.get("events.shot_noise_hz");
        match self.lux() {
            lux if lux > 0.0 => {
                crate::light::event_shot_noise_hz(lux, own, self.get("light.dim_shot_hz_lx"))
            }
            _ => own,
        }
    }

    /// The RGB sensor's terms; under a modelled light level the blur is at least the
    /// exposure's.
    pub fn rgb(&self) -> RgbNoise {
        let lux = self.lux();
        let own_blur = self.get("rgb.blur_renders") as u32;
        RgbNoise {
            read_noise_grey: self.get("rgb.read_noise_grey"),
            exposure_scale: self.get("rgb.exposure_scale"),
            blur_renders: if lux > 0.0 {
                own_blur.max(crate::light::RGB_CAMERA.blur_renders(lux))
            } else {
                own_blur
            },
            lux,
        }
    }

    /// The sensor link's terms.
    pub fn link(&self) -> LinkNoise {
        LinkNoise {
            drop_rate: self.get("link.drop_rate"),
            delay_ms: self.get("link.delay_ms"),
        }
    }

    /// Placement jitter: (σ position m, σ yaw rad).
    pub fn placement_sigma(&self) -> (f64, f64) {
        (
            self.get("geometry.position_sigma_m"),
            self.get("geometry.yaw_sigma_deg").to_radians(),
        )
    }

    /// σ of the gust force on the performer, N.
    pub fn gust_sigma_n(&self) -> f64 {
        self.get("flight.gust_sigma_n")
    }

    /// How long each gust holds, ns.
    pub fn gust_period_ns(&self) -> u64 {
        (self.get("flight.gust_period_ms") * 1e6).round() as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_off() {
        let none = Perturbation::default();
        assert!(none.is_none());
        assert!(none.event_noise(3).is_ideal());
        assert!(none.rgb().is_ideal());
        assert!(none.link().is_ideal());
        assert!(!none.reflies());
    }

    #[test]
    fn assignments_parse_and_record_only_what_differs() {
        let p = Perturbation::parse(&[
            "events.shot_noise_hz=0.5",
            " rgb.read_noise_grey = 3 ",
            "rgb.exposure_scale=1",
        ])
        .unwrap();
        assert_eq!(p.get("events.shot_noise_hz"), 0.5);
        assert_eq!(p.event_noise(1).shot_noise_hz, 0.5);
        assert_eq!(p.rgb().read_noise_grey, 3.0);
        let keys: Vec<&str> = p.non_default().keys().copied().collect();
        assert_eq!(keys, ["events.shot_noise_hz", "rgb.read_noise_grey"]);
    }

    #[test]
    fn bad_terms_name_themselves() {
        let e = Perturbation::parse(&["events.shot_noise=1"]).unwrap_err();
        assert!(e.to_string().contains("\"events.shot_noise\""), "{e}");
        let e = Perturbation::parse(&["link.drop_rate=-0.1"]).unwrap_err();
        assert!(e.to_string().contains("link.drop_rate"), "{e}");
        let e = Perturbation::parse(&["events.hot_pixels=2.5"]).unwrap_err();
        assert!(e.to_string().contains("whole number"), "{e}");
        let e = Perturbation::parse(&["rgb.read_noise_grey=nan"]).unwrap_err();
        assert!(matches!(e, PerturbError::OutOfRange { .. }), "{e}");
        let e = Perturbation::parse(&["rgb.read_noise_grey"]).unwrap_err();
        assert!(matches!(e, PerturbError::NotAnAssignment(_)), "{e}");
        let e = Perturbation::parse(&["rgb.read_noise_grey=lots"]).unwrap_err();
        assert!(e.to_string().contains("lots"), "{e}");
    }

    #[test]
    fn a_light_level_too_dark_for_the_event_model_is_refused_naming_it() {
        // The earlier assumption adds 10 Hz·lx / E: 0.1 lx is the 100 Hz per pixel the term
        // allows.
        let assumed = "light.dim_shot_hz_lx=10";
        assert!(Perturbation::parse(&[assumed, "light.lux=0.1"]).is_ok());
        let e = Perturbation::parse(&[assumed, "light.lux=0.05"]).unwrap_err();
        assert!(matches!(e, PerturbError::TooDark { .. }), "{e}");
        let text = e.to_string();
        assert!(
            text.contains("light.lux = 0.05") && text.contains("200"),
            "{text}"
        );
        assert!(text.contains("at least 0.100 lx"), "{text}");
        // The measured constant, 0.8486 Hz·lx, allows down to ≈ 0.0085 lx.
        assert!(Perturbation::parse(&["light.lux=0.01"]).is_ok());
        let e = Perturbation::parse(&["light.lux=0.005"])
            .unwrap_err()
            .to_string();
        assert!(e.contains("at least 0.008 lx"), "{e}");
        // The sensor's own shot noise counts, in any order of the terms.
        for terms in [
            [assumed, "light.lux=0.2", "events.shot_noise_hz=60"],
            ["events.shot_noise_hz=60", "light.lux=0.2", assumed],
        ] {
            let e = Perturbation::parse(&terms).unwrap_err().to_string();
            assert!(e.contains("at least 0.250 lx"), "{e}");
        }
        assert!(
            Perturbation::parse(&[assumed, "events.shot_noise_hz=60", "light.lux=0.25"]).is_ok()
        );
        // Only the whole set is judged: a later term may bring it back in range.
        let mut p = Perturbation::parse(&[assumed, "events.shot_noise_hz=60"]).unwrap();
        p.set("light.lux", 0.2).unwrap();
        assert!(p.check().is_err());
        p.set("events.shot_noise_hz", 0.0).unwrap();
        assert_eq!(p.check(), Ok(()));
        let e = Perturbation::parse(&["events.shot_noise_hz=100", "light.lux=1000"]).unwrap_err();
        assert!(!e.to_string().contains("at least"), "{e}");
    }

    #[test]
    fn the_light_terms_move_the_event_sensor_only_under_a_light_level() {
        let noise = |terms: &[&str]| Perturbation::parse(terms).unwrap().event_noise(1);
        let unlit = noise(&["light.cutoff_scale=3", "light.dim_shot_hz_lx=10"]);
        assert_eq!(unlit, noise(&[]));
        let office = noise(&["light.lux=500"]);
        assert_eq!(office.cutoff_hz, 300.0);
        assert!(
            (office.shot_noise_hz - crate::light::MEASURED_DIM_SHOT_HZ_LX / 500.0).abs() < 1e-12
        );
        let wide = noise(&["light.lux=500", "light.cutoff_scale=3"]);
        assert!((wide.cutoff_hz - 900.0).abs() < 1e-9);
        let assumed = noise(&["light.lux=5", "light.dim_shot_hz_lx=10"]);
        assert!((assumed.shot_noise_hz - 2.0).abs() < 1e-12);
        for bad in ["light.cutoff_scale=0", "light.dim_shot_hz_lx=-1"] {
            let e = Perturbation::parse(&[bad]).unwrap_err().to_string();
            assert!(e.contains(bad.split('=').next().unwrap()), "{e}");
        }
    }

    #[test]
    fn every_default_is_in_range_and_keys_are_unique() {
        for (i, p) in PARAMETERS.iter().enumerate() {
            assert!(p.min <= p.default && p.default <= p.max, "{}", p.key);
            assert!(PARAMETERS[i + 1..].iter().all(|q| q.key != p.key));
            let mut x = Perturbation::default();
            x.set(p.key, p.default).unwrap();
            assert!(x.is_none(), "{}", p.key);
        }
    }
}
