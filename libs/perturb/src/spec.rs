//! The perturbation parameters: one table of named terms with units, defaults and limits, and
//! the set of values a trial runs with.
//!
//! A term is written `group.name=value` (`--perturb events.shot_noise_hz=0.5`, a study file's
//! level); every default means "off", so an empty [`Perturbation`] is today's noiseless run.

use std::collections::BTreeMap;

use std::sync::Arc;

use event_camera::real_noise::RealNoise;
use event_camera::{EventNoise, EventSensorModel};

use crate::error::PerturbError;
use crate::link::LinkNoise;
use crate::rgb::RgbNoise;

/// One perturbation term.
#[derive(Debug, Clone, Copy)]
pub struct Parameter {
    /// `group.name`, the unit last (`events.shot_noise_hz`).
    pub key: &'static str,
    pub unit: &'static str,
    /// The value that switches the term off.
    pub default: f64,
    pub min: f64,
    pub max: f64,
    /// Only whole numbers are meaningful.
    pub integer: bool,
    pub doc: &'static str,
}

const fn p(
    key: &'static str,
    unit: &'static str,
    default: f64,
    min: f64,
    max: f64,
    integer: bool,
    doc: &'static str,
) -> Parameter {
    Parameter {
        key,
        unit,
        default,
        min,
        max,
        integer,
        doc,
    }
}

/// Every term, by group (the order of `waggle trials --help` and of the docs).
pub const PARAMETERS: &[Parameter] = &[
    p(
        "events.threshold",
        "log intensity",
        event_camera::DEFAULT_THRESHOLD,
        0.01,
        2.0,
        false,
        "nominal contrast threshold C of every pixel (the paper's sensor: 0.18; v2e: 0.2)",
    ),
    p(
        "events.threshold_sigma",
        "log intensity",
        0.0,
        0.0,
        1.0,
        false,
        "per-pixel contrast-threshold mismatch: σ of each pixel's threshold around C",
    ),
    p(
        "events.refractory_ms",
        "ms",
        0.0,
        0.0,
        1000.0,
        false,
        "refractory period: a pixel emits nothing this long after an event (its level follows)",
    ),
    p(
        "events.leak_hz",
        "Hz",
        0.0,
        0.0,
        100.0,
        false,
        "leak: a static pixel emits ON events at this rate (reference drifts down by rate·C per s)",
    ),
    p(
        "events.leak_spread_decades",
        "decades",
        0.0,
        0.0,
        1.0,
        false,
        "leak-rate spread: σ of log10 of each pixel's leak rate (v2e noise_rate_cov_decades)",
    ),
    p(
        "events.leak_jitter",
        "fraction",
        0.0,
        0.0,
        1.0,
        false,
        "leak jitter: relative σ of each pixel's leak rate, redrawn every leak period",
    ),
    p(
        "events.shot_noise_hz",
        "Hz per pixel",
        0.0,
        0.0,
        100.0,
        false,
        "shot noise: spurious events per pixel (Poisson, either polarity)",
    ),
    p(
        "events.shot_noise_bright_drop",
        "fraction",
        0.0,
        0.0,
        1.0,
        false,
        "shot noise falls by this fraction at white: rate × (1 − b·(Y+20)/275) (v2e: 0.75)",
    ),
    p(
        "events.cutoff_hz",
        "Hz",
        0.0,
        0.0,
        10_000.0,
        false,
        "photoreceptor cutoff at white; scales with intensity (Y+20)/275 (0 = unlimited)",
    ),
    p(
        "events.linlog_dn",
        "luminance 0–255",
        0.0,
        0.0,
        255.0,
        false,
        "lin-log curve: log intensity is linear below this luminance (v2e: 20; 0 = pure log)",
    ),
    p(
        "events.hot_pixels",
        "pixels",
        0.0,
        0.0,
        100_000.0,
        true,
        "hot pixels: this many pixels fire ON events at events.hot_pixel_hz",
    ),
    p(
        "events.hot_pixel_hz",
        "Hz",
        50.0,
        0.001,
        1000.0,
        false,
        "rate of each hot pixel",
    ),
    p(
        "events.real_noise_copies",
        "copies",
        1.0,
        1.0,
        event_camera::real_noise::MAX_COPIES as f64,
        true,
        "with a real-noise source (--real-noise FILE): copies of its background laid over the \
         sensor, each at its own seeded offset in time and image (the rate × copies)",
    ),
    p(
        "events.real_noise_fitted",
        "0/1",
        0.0,
        0.0,
        1.0,
        true,
        "with a real-noise source: 1 replaces its events by the model's terms fitted from the \
         same background (shot noise, leak, hot pixels, each × events.real_noise_copies)",
    ),
    p(
        "rgb.read_noise_grey",
        "grey levels",
        0.0,
        0.0,
        128.0,
        false,
        "read noise: σ of a Gaussian added to every pixel and channel (0–255 scale)",
    ),
    p(
        "rgb.exposure_scale",
        "×",
        1.0,
        0.01,
        100.0,
        false,
        "illumination/exposure gain on every value (clamped to 0–255)",
    ),
    p(
        "rgb.blur_renders",
        "renders",
        1.0,
        1.0,
        4.0,
        true,
        "motion blur: each frame is the mean of this many 10 ms renders (1 = none)",
    ),
    p(
        "light.lux",
        "lx",
        0.0,
        0.0,
        100_000.0,
        false,
        "scene illuminance for both cameras: RGB exposure, photon and read noise, blur; event \
         bandwidth and background (0 = light not modelled; darkness adds light.dim_shot_hz_lx / \
         E of shot noise, and events.shot_noise_hz with it must stay within 100 Hz per pixel)",
    ),
    p(
        "light.dim_shot_hz_lx",
        "Hz·lx",
        crate::light::MEASURED_DIM_SHOT_HZ_LX,
        0.0,
        1000.0,
        false,
        "under light.lux: the shot noise darkness adds, Hz per pixel times lx (default measured \
         on a real sensor by IEBCS at 0.1 lx; 10 is the earlier assumption of 10 Hz at 1 lx)",
    ),
    p(
        "light.cutoff_scale",
        "×",
        1.0,
        0.01,
        100.0,
        false,
        "under light.lux: scales the assumed photoreceptor bandwidth (the event cutoff at a light \
         level; 1 places v2e's 300 Hz at 500 lx)",
    ),
    p(
        "geometry.position_sigma_m",
        "m",
        0.0,
        0.0,
        0.5,
        false,
        "observer placement jitter: σ of each home coordinate (x, y, z); the camera re-aims",
    ),
    p(
        "geometry.yaw_sigma_deg",
        "°",
        0.0,
        0.0,
        30.0,
        false,
        "observer heading jitter: σ added to each observer's yaw after aiming",
    ),
    p(
        "flight.gust_sigma_n",
        "N",
        0.0,
        0.0,
        0.5,
        false,
        "gusts: σ of a horizontal force on the performer (physics), redrawn every gust period",
    ),
    p(
        "flight.gust_period_ms",
        "ms",
        500.0,
        10.0,
        10_000.0,
        false,
        "how long each gust force holds",
    ),
    p(
        "flight.cascade",
        "0/1",
        0.0,
        0.0,
        1.0,
        true,
        "1: every drone flies the Crazyflie-like cascade (thrust/tilt limits, noisy delayed \
         estimate) instead of the ideal stabilisation",
    ),
    p(
        "flight.estimate_sigma_m",
        "m",
        0.02,
        0.0,
        0.5,
        false,
        "cascade only: σ of each axis of the position estimate's error (Gauss–Markov, 0.2 s)",
    ),
    p(
        "flight.estimate_latency_ms",
        "ms",
        4.0,
        0.0,
        100.0,
        false,
        "cascade only: age of the state estimate (rounded to the 2 ms physics step)",
    ),
    p(
        "flight.attitude_sigma_deg",
        "°",
        0.0,
        0.0,
        10.0,
        false,
        "σ of each axis of the observers' attitude estimate's error (Gauss–Markov), which their \
         receivers undo as if it were the airframe's turn",
    ),
    p(
        "flight.attitude_tau_s",
        "s",
        1.0,
        0.01,
        1000.0,
        false,
        "correlation time of the attitude estimate's error (long: a bias that holds over a \
         gesture; short: jitter)",
    ),
    p(
        "wind.mean_mps",
        "m/s",
        0.0,
        0.0,
        20.0,
        false,
        "mean horizontal wind over the scene (every drone; Crazyflie rotor drag)",
    ),
    p(
        "wind.direction_deg",
        "°",
        0.0,
        0.0,
        360.0,
        false,
        "direction the mean wind blows towards, anticlockwise from world +x",
    ),
    p(
        "wind.sigma_mps",
        "m/s",
        0.0,
        0.0,
        5.0,
        false,
        "Dryden turbulence: horizontal σ_u = σ_v; σ_w = 0.51 σ_u (MIL-HDBK-1797 low altitude)",
    ),
    p(
        "wind.intensity",
        "σ/mean",
        0.0,
        0.0,
        1.0,
        false,
        "turbulence intensity: adds intensity × wind.mean_mps to wind.sigma_mps (so one value \
         scales the gusts with the mean wind, as in a study over wind speeds)",
    ),
    p(
        "wind.length_m",
        "m",
        0.0,
        0.0,
        1000.0,
        false,
        "Dryden length scale L_u = L_v (L_w = 0.132 L_u); 0 = the low-altitude form's 23 m",
    ),
    p(
        "link.drop_rate",
        "probability",
        0.0,
        0.0,
        1.0,
        false,
        "loss: each sensor message (frame or event packet) is lost with this probability",
    ),
    p(
        "link.delay_ms",
        "ms",
        0.0,
        0.0,
        10_000.0,
        false,
        "constant delay of every sensor message (shifts every release by the same time)",
    ),
];

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
