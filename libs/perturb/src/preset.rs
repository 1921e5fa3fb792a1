//! Named sensor presets: sets of `events.*` terms taken from a cited source, selectable by name
//! (`--sensor-preset v2e-noisy`, a study file's `sensor_preset`). A preset is a starting point:
//! terms given explicitly (`--perturb`) override it.
//!
//! The v2e presets carry v2e's own values (Y. Hu, S.-C. Liu, T. Delbruck, "v2e: From Video
//! Frames to Realistic DVS Events", CVPRW 2021; SensorsINI/v2e at commit cac6384 (2025-10-17):
//! `emulator.py`'s `set_dvs_params` for `--dvs_params clean` and `noisy`, `v2e_args.py`'s
//! defaults when none is given, `emulator_utils.py` for the lin-log knee and the shot-noise
//! intensity factor). Where v2e models a term this crate does not, the preset says so in
//! [`Preset::unmodelled`] and the term is left out rather than approximated silently.
//! `libs/event-camera/tests/v2e.rs` checks the model with these values against v2e's output.

use crate::error::PerturbError;
use crate::spec::{Perturbation, find_named};

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

/// v2e's terms that every parameter set keeps: the lin-log knee (`emulator_utils.lin_log`, 20
/// DN), leak jitter and leak-rate spread (`leak_jitter_fraction` 0.1, `noise_rate_cov_decades`
/// 0.1) and shot noise at 0.25× in white (`SHOT_NOISE_INTEN_FACTOR`).
macro_rules! v2e_shape {
    () => {
        [
            ("events.threshold", 0.2),
            ("events.linlog_dn", 20.0),
            ("events.leak_spread_decades", 0.1),
            ("events.leak_jitter", 0.1),
            ("events.shot_noise_bright_drop", 0.75),
        ]
    };
}

const V2E_CLEAN: [(&str, f64); 6] = {
    let [a, b, c, d, e] = v2e_shape!();
    [a, b, c, d, e, ("events.threshold_sigma", 0.02)]
};

const V2E_DEFAULT: [(&str, f64); 10] = {
    let [a, b, c, d, e] = v2e_shape!();
    [
        a,
        b,
        c,
        d,
        e,
        ("events.threshold_sigma", 0.03),
        ("events.refractory_ms", V2E_REFRACTORY_MS),
        ("events.cutoff_hz", 300.0),
        ("events.leak_hz", 0.01),
        ("events.shot_noise_hz", 0.001),
    ]
};

const V2E_NOISY: [(&str, f64); 9] = {
    let [a, b, c, d, e] = v2e_shape!();
    [
        a,
        b,
        c,
        d,
        e,
        ("events.threshold_sigma", 0.05),
        ("events.cutoff_hz", 30.0),
        ("events.leak_hz", 0.1),
        ("events.shot_noise_hz", 5.0),
    ]
};

/// v2e-noisy's sensor with the background activity measured on a real sensor in dim light.
const DVS_DIM: [(&str, f64); 9] = {
    let mut terms = V2E_NOISY;
    terms[8] = ("events.shot_noise_hz", 10.0);
    terms
};

/// Every preset, by name.
pub const PRESETS: &[Preset] = &[
    Preset {
        name: "v2e-clean",
        source: "v2e --dvs_params clean (emulator.py set_dvs_params)",
        terms: &V2E_CLEAN,
        unmodelled: "separate ON/OFF threshold mismatch",
    },
    Preset {
        name: "v2e-default",
        source: "v2e without --dvs_params (v2e_args.py defaults)",
        terms: &V2E_DEFAULT,
        unmodelled: "separate ON/OFF threshold mismatch",
    },
    Preset {
        name: "v2e-noisy",
        source: "v2e --dvs_params noisy (emulator.py set_dvs_params)",
        terms: &V2E_NOISY,
        unmodelled: "separate ON/OFF threshold mismatch",
    },
    Preset {
        name: "dvs-dim",
        source: "v2e-noisy with 10 Hz per pixel of background activity: the dim-light figure \
                 of a real DAVIS346 (Guo & Delbruck, IEEE TPAMI 2023, DND21 recordings); no \
                 light level is modelled in this preset, so the photoreceptor cutoff stays \
                 v2e-noisy's (the light.lux term models one)",
        terms: &DVS_DIM,
        unmodelled: "separate ON/OFF threshold mismatch; cutoff not derived from a light level",
    },
];

/// The preset called `name`.
pub fn preset(name: &str) -> Result<&'static Preset, PerturbError> {
    find_named(PRESETS, name, |p| p.name).map_err(|known| PerturbError::UnknownPreset {
        name: name.to_owned(),
        known,
    })
}

/// True when `--sensor-preset`'s value names a preset file rather than a built-in preset
/// (whose names hold neither `.` nor `/`).
pub fn is_preset_file(name: &str) -> bool {
    name.contains('.') || name.contains('/')
}

/// The assignments of a preset file's text (as `waggle sensor-fit --out` writes it): one
/// `KEY = VALUE` per line, `#` comments and blank lines skipped. The terms are checked when
/// applied, like `--perturb`'s.
pub fn parse_preset_file(text: &str) -> Result<Vec<String>, PerturbError> {
    let mut terms = Vec::new();
    for (k, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let Some((key, value)) = line.split_once('=') else {
            return Err(PerturbError::PresetFileLine {
                line: k + 1,
                reason: format!("{line:?} is not KEY = VALUE"),
            });
        };
        terms.push(format!("{}={}", key.trim(), value.trim()));
    }
    Ok(terms)
}

impl Perturbation {
    /// A preset file's `terms` (from [`parse_preset_file`]), then `assignments` over them.
    pub fn with_preset_terms<S: AsRef<str>>(
        terms: &[String],
        assignments: &[S],
    ) -> Result<Self, PerturbError> {
        let mut p = Self::default();
        for a in terms
            .iter()
            .map(String::as_str)
            .chain(assignments.iter().map(AsRef::as_ref))
        {
            p.assign(a)?;
        }
        p.check()?;
        Ok(p)
    }

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
        p.check()?;
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
    fn preset_files_parse_and_apply_with_overrides() {
        let text = "# fitted\nevents.shot_noise_hz = 2.5\n\nevents.leak_hz=0.2 # ON only\n";
        let terms = parse_preset_file(text).unwrap();
        assert_eq!(terms, ["events.shot_noise_hz=2.5", "events.leak_hz=0.2"]);
        let p = Perturbation::with_preset_terms(&terms, &["events.leak_hz=0.3"]).unwrap();
        assert_eq!(p.get("events.shot_noise_hz"), 2.5);
        assert_eq!(p.get("events.leak_hz"), 0.3);
        assert_eq!(
            parse_preset_file("events.leak_hz 0.2"),
            Err(PerturbError::PresetFileLine {
                line: 1,
                reason: "\"events.leak_hz 0.2\" is not KEY = VALUE".into()
            })
        );
        let bad = parse_preset_file("events.loud = 1").unwrap();
        assert!(Perturbation::with_preset_terms::<&str>(&bad, &[]).is_err());
        assert!(is_preset_file("fit/davis.preset") && is_preset_file("dim.toml"));
        assert!(PRESETS.iter().all(|p| !is_preset_file(p.name)));
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
        for name in ["v2e-clean", "v2e-default", "v2e-noisy", "dvs-dim"] {
            assert_eq!(get(name, "events.threshold").unwrap().1, 0.2, "{name}");
            assert_eq!(get(name, "events.linlog_dn").unwrap().1, 20.0, "{name}");
            assert_eq!(get(name, "events.leak_jitter").unwrap().1, 0.1, "{name}");
            assert_eq!(
                get(name, "events.leak_spread_decades").unwrap().1,
                0.1,
                "{name}"
            );
            assert_eq!(
                get(name, "events.shot_noise_bright_drop").unwrap().1,
                0.75,
                "{name}"
            );
        }
        assert_eq!(get("v2e-default", "events.cutoff_hz").unwrap().1, 300.0);
        assert_eq!(get("v2e-noisy", "events.cutoff_hz").unwrap().1, 30.0);
        assert!(get("v2e-clean", "events.cutoff_hz").is_none());
        assert_eq!(get("dvs-dim", "events.shot_noise_hz").unwrap().1, 10.0);
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
