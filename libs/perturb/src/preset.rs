//! Named sensor presets: sets of `events.*` terms taken from a cited source, selectable by name
//! (`--sensor-preset v2e-noisy`, a study file's `sensor_preset`). A preset is a starting point:
//! terms given explicitly (`--perturb`) override it.
//!
//! The v2e presets carry v2e's own values (Y. Hu, S.-C. Liu, T. Delbruck, "v2e: From Video
//! Frames to Realistic DVS Events", CVPRW 2021; SensorsINI/v2e at commit cac6384 (2025-10-17):
//! `emulator.py`'s `set_dvs_params` for `--dvs_params clean` and `noisy`, `v2e_args.py`'s
//! defaults when none is given). Where v2e models a term
//! this crate does not yet, the preset says so in [`Preset::unmodelled`] and the term is left out
//! rather than approximated silently.

use crate::spec::{PerturbError, Perturbation, find_named};

/// One named preset.
#[derive(Debug, Clone, Copy)]
pub struct Preset {
    pub name: &'static str,
    /// Where the values come from.
    pub source: &'static str,
    /// `(term, value)`, applied in order.
    pub terms: &'static [(&'static str, f64)],
    /// The source's terms that Waggle's sensor model does not have yet (empty: none).
    pub unmodelled: &'static str,
}

/// v2e's refractory period when no `--dvs_params` is given (`v2e_args.py`); its `clean` and
/// `noisy` parameter sets turn the refractory period off (`emulator.py`, `set_dvs_params`).
const V2E_REFRACTORY_MS: f64 = 0.5;

/// Every preset, by name.
pub const PRESETS: &[Preset] = &[
    Preset {
        name: "v2e-clean",
        source: "v2e --dvs_params clean (emulator.py set_dvs_params)",
        terms: &[("events.threshold", 0.2), ("events.threshold_sigma", 0.02)],
        unmodelled: "",
    },
    Preset {
        name: "v2e-default",
        source: "v2e without --dvs_params (v2e_args.py defaults)",
        terms: &[
            ("events.threshold", 0.2),
            ("events.threshold_sigma", 0.03),
            ("events.refractory_ms", V2E_REFRACTORY_MS),
            ("events.leak_hz", 0.01),
            ("events.shot_noise_hz", 0.001),
        ],
        unmodelled: "photoreceptor cutoff 300 Hz, leak jitter 10 %, shot noise scaled by \
                     intensity, leak-rate spread 0.1 decades, lin-log curve below 20 DN",
    },
    Preset {
        name: "v2e-noisy",
        source: "v2e --dvs_params noisy (emulator.py set_dvs_params)",
        terms: &[
            ("events.threshold", 0.2),
            ("events.threshold_sigma", 0.05),
            ("events.leak_hz", 0.1),
            ("events.shot_noise_hz", 5.0),
        ],
        unmodelled: "photoreceptor cutoff 30 Hz, leak jitter 10 %, shot noise scaled by \
                     intensity, leak-rate spread 0.1 decades, lin-log curve below 20 DN",
    },
];

/// The preset called `name`.
pub fn preset(name: &str) -> Result<&'static Preset, PerturbError> {
    find_named(PRESETS, name, |p| p.name).map_err(|known| PerturbError::UnknownPreset {
        name: name.to_owned(),
        known,
    })
}

impl Perturbation {
    /// The preset `name`'s terms (none: nothing), then `assignments` (`KEY=VALUE` each) over
    /// them.
    pub fn with_preset<S: AsRef<str>>(
        name: Option<&str>,
        assignments: &[S],
    ) -> Result<Self, PerturbError> {
        let mut p = Self::default();
        if let Some(name) = name {
            for &(key, value) in preset(name)?.terms {
                p.set(key, value)?;
            }
        }
        for a in assignments {
            p.assign(a.as_ref())?;
        }
        Ok(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_preset_is_in_range_and_named_once() {
        for (i, preset) in PRESETS.iter().enumerate() {
            assert!(PRESETS[i + 1..].iter().all(|q| q.name != preset.name));
            let p = Perturbation::with_preset::<&str>(Some(preset.name), &[])
                .unwrap_or_else(|e| panic!("{}: {e}", preset.name));
            assert!(!p.is_none(), "{}", preset.name);
            for &(key, value) in preset.terms {
                assert_eq!(p.get(key), value, "{} {key}", preset.name);
            }
        }
    }

    #[test]
    fn v2e_values() {
        let get = |name: &str, key: &str| preset(name).unwrap().terms.iter().find(|t| t.0 == key);
        assert_eq!(
            get("v2e-default", "events.threshold_sigma").unwrap().1,
            0.03
        );
        assert_eq!(get("v2e-default", "events.leak_hz").unwrap().1, 0.01);
        assert_eq!(get("v2e-default", "events.shot_noise_hz").unwrap().1, 0.001);
        assert_eq!(get("v2e-noisy", "events.shot_noise_hz").unwrap().1, 5.0);
        assert_eq!(get("v2e-noisy", "events.leak_hz").unwrap().1, 0.1);
        assert_eq!(get("v2e-noisy", "events.threshold_sigma").unwrap().1, 0.05);
        assert!(get("v2e-clean", "events.shot_noise_hz").is_none());
        for name in ["v2e-clean", "v2e-default", "v2e-noisy"] {
            assert_eq!(get(name, "events.threshold").unwrap().1, 0.2, "{name}");
        }
        // Only v2e's defaults have a refractory period; `clean` and `noisy` set it to 0.
        assert_eq!(get("v2e-default", "events.refractory_ms").unwrap().1, 0.5);
        assert!(get("v2e-clean", "events.refractory_ms").is_none());
        assert!(get("v2e-noisy", "events.refractory_ms").is_none());
    }

    #[test]
    fn explicit_terms_override_a_preset_and_unknown_names_are_refused() {
        let p = Perturbation::with_preset(Some("v2e-noisy"), &["events.shot_noise_hz=1"]).unwrap();
        assert_eq!(p.get("events.shot_noise_hz"), 1.0);
        assert_eq!(p.get("events.leak_hz"), 0.1);
        let e = Perturbation::with_preset::<&str>(Some("v2e-loud"), &[]).unwrap_err();
        assert!(e.to_string().contains("\"v2e-loud\""), "{e}");
        assert!(e.to_string().contains("v2e-noisy"), "{e}");
        assert!(
            Perturbation::with_preset::<&str>(None, &[])
                .unwrap()
                .is_none()
        );
    }
}
