//! Link study files (`waggle study FILE`, the built-in ones in [`crate::study`]): the TOML's
//! fields, its parse and the checks that need no simulator, file system or plug-in — the
//! criterion, the trial count, non-empty conditions, crossed conditions that differ, a plug-in's
//! time limit — and the settings a study runs. The lab turns a checked study into points
//! (perturbations, formations, receivers) and runs them; a merge reads back the TOML the lab
//! printed into `run.json`.

use std::collections::BTreeMap;

use proto::Modality;
use serde::{Deserialize, Serialize};

/// The only criterion of a link study: every observer releases exactly the broadcast.
pub const EXACT_PAYLOADS: &str = "exact-payloads";

/// The condition whose levels are broadcast payloads: each level is a six-bit payload's value
/// (`26` is `011010`), and the point broadcasts that one payload instead of the study's `link`.
pub const LINK_PAYLOAD: &str = "link.payload";

/// The payload a `link.payload` level names, if it is one (an integer 0–63).
pub fn payload_level(level: f64) -> Option<u8> {
    (level.fract() == 0.0 && (0.0..=63.0).contains(&level)).then_some(level as u8)
}

/// A level as reports and directory names show it: a payload as its six bits, any other level
/// as its number.
pub fn level_text(key: &str, level: f64) -> String {
    match payload_level(level) {
        Some(p) if key == LINK_PAYLOAD => format!("{p:06b}"),
        _ => format!("{level}"),
    }
}

/// The most settings a crossed study may combine its conditions into (each is a point per
/// modality, each point its trials): far beyond any study run, well within memory.
pub const MAX_CROSSED_SETTINGS: usize = 100_000;

/// Why a study file is refused by the checks of this module (each names its field).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StudyFileError {
    #[error("criterion {0:?}: the only link criterion is {EXACT_PAYLOADS:?}", EXACT_PAYLOADS = EXACT_PAYLOADS)]
    Criterion(String),
    #[error("trials must be at least 1")]
    NoTrials,
    #[error("modalities, vary and every vary.levels must not be empty")]
    Empty,
    #[error("cross: every vary.key must be a different condition")]
    CrossRepeats,
    #[error(
        "cross: the conditions' levels combine into {settings} settings; at most \
         {MAX_CROSSED_SETTINGS} (split the study)"
    )]
    CrossTooLarge { settings: u128 },
    #[error("plugin_time_limit_s = {0}: give 0 < seconds ≤ 86400")]
    TrialLimit(f64),
}

/// One condition of a study: a perturbation term (or, in link studies, a viewpoint axis) and
/// the levels it takes.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Vary {
    /// A perturbation term (`events.shot_noise_hz`) or, in link studies, a viewpoint axis.
    pub key: String,
    /// The values it takes, one point each.
    pub levels: Vec<f64>,
}

/// A study file.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct StudyFile {
    /// The study's name, as its report gives it.
    pub name: String,
    /// The cameras each point runs with: `rgb`, `events`.
    pub modalities: Vec<Modality>,
    /// The broadcast payloads, six bits each (`011010`).
    pub link: Vec<String>,
    /// Observers in the standard formation (default 1).
    #[serde(default)]
    pub observers: Option<usize>,
    /// One observer placed at `[azimuth°, elevation°, distance m]` instead of the formation.
    #[serde(default)]
    pub viewpoint: Option<[f64; 3]>,
    /// Seeded trials per point.
    pub trials: u64,
    /// The study's base seed; each trial's seed derives from it (default 0).
    #[serde(default)]
    pub seed: u64,
    /// What a successful trial is: only `exact-payloads` (every observer releases exactly the
    /// broadcast).
    pub criterion: String,
    /// A named sensor preset (`perturb::preset`) every point starts from, under `fixed`.
    #[serde(default)]
    pub sensor_preset: Option<String>,
    /// Perturbation terms every point holds (`{ "wind.intensity" = 0.25 }`).
    #[serde(default)]
    pub fixed: BTreeMap<String, f64>,
    /// A real recording's background over every point's event sensor (as `waggle trials
    /// --real-noise`: a path or `PACKAGE/FILE`; RGB points are not affected).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub real_noise: Option<String>,
    /// Its static stretch, `[start_s, end_s]` from its first event (default: isolated events).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub real_noise_static: Option<[f64; 2]>,
    /// The receivers' viewpoint rectification: `off`, `pitched` (default) or `frontal`.
    #[serde(default)]
    pub rectify: Option<String>,
    /// Cross the conditions: a point for every combination of their levels (otherwise each is
    /// varied alone).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub cross: bool,
    /// The receivers each modality's points run with: `waggle` (Waggle's own, the default) and
    /// plug-ins `python:MODULE:CLASS`, all on the same flights and seeds.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub receivers: Vec<String>,
    /// Wall-clock limit of one trial of a plug-in receiver, seconds (default 600).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plugin_time_limit_s: Option<f64>,
    /// The conditions: each a term (or viewpoint axis) and its levels.
    pub vary: Vec<Vary>,
}

impl StudyFile {
    /// Parses a study's TOML text (an unknown or mistyped field is refused, named).
    pub fn from_toml(text: &str) -> Result<Self, toml::de::Error> {
        toml::from_str(text)
    }

    /// The study as TOML, as `run.json` records it for a merge to read back.
    pub fn to_toml(&self) -> Result<String, toml::ser::Error> {
        toml::to_string(self)
    }

    /// The first checks of a study's points: the criterion, the trial count, and modalities and
    /// conditions that are not empty.
    pub fn check_shape(&self) -> Result<(), StudyFileError> {
        if self.criterion != EXACT_PAYLOADS {
            return Err(StudyFileError::Criterion(self.criterion.clone()));
        }
        if self.trials == 0 {
            return Err(StudyFileError::NoTrials);
        }
        if self.modalities.is_empty()
            || self.vary.is_empty()
            || self.vary.iter().any(|v| v.levels.is_empty())
        {
            return Err(StudyFileError::Empty);
        }
        Ok(())
    }

    /// A crossed study's conditions are all different.
    pub fn check_cross(&self) -> Result<(), StudyFileError> {
        if self.cross
            && self
                .vary
                .iter()
                .enumerate()
                .any(|(i, v)| self.vary[..i].iter().any(|w| w.key == v.key))
        {
            return Err(StudyFileError::CrossRepeats);
        }
        if self.cross {
            // The product is formed before `settings` would allocate it: a few lines of TOML
            // can ask for more combinations than any machine holds.
            let settings = self
                .vary
                .iter()
                .map(|v| v.levels.len() as u128)
                .fold(1u128, u128::saturating_mul);
            if settings > MAX_CROSSED_SETTINGS as u128 {
                return Err(StudyFileError::CrossTooLarge { settings });
            }
        }
        Ok(())
    }

    /// How long one trial of a plug-in receiver may take (default 600 s).
    pub fn trial_limit(&self) -> Result<std::time::Duration, StudyFileError> {
        match self.plugin_time_limit_s {
            None => Ok(std::time::Duration::from_secs(600)),
            Some(s) if s.is_finite() && s > 0.0 && s <= 86_400.0 => {
                Ok(std::time::Duration::from_secs_f64(s))
            }
            Some(s) => Err(StudyFileError::TrialLimit(s)),
        }
    }

    /// The settings the study runs, each a list of (key, level): one per level of each
    /// condition, or with `cross`, every combination of the conditions' levels (the first
    /// condition outermost).
    pub fn settings(&self) -> Vec<Vec<(&str, f64)>> {
        if !self.cross {
            return self
                .vary
                .iter()
                .flat_map(|v| v.levels.iter().map(|&l| vec![(v.key.as_str(), l)]))
                .collect();
        }
        let mut all: Vec<Vec<(&str, f64)>> = vec![Vec::new()];
        for v in &self.vary {
            all = all
                .into_iter()
                .flat_map(|prefix| {
                    v.levels.iter().map(move |&l| {
                        let mut s = prefix.clone();
                        s.push((v.key.as_str(), l));
                        s
                    })
                })
                .collect();
        }
        all
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn crossed(levels_per_condition: &[usize]) -> String {
        let mut text = String::from(
            "name = \"x\"\nmodalities = [\"events\"]\nlink = [\"011010\"]\nobservers = 1\n\
             trials = 1\nseed = 1\ncriterion = \"exact-payloads\"\ncross = true\n",
        );
        for (i, &n) in levels_per_condition.iter().enumerate() {
            let levels: Vec<String> = (0..n).map(|l| format!("{l}.0")).collect();
            text += &format!(
                "[[vary]]\nkey = \"k{i}\"\nlevels = [{}]\n",
                levels.join(", ")
            );
        }
        text
    }

    #[test]
    fn a_crossed_study_too_large_to_hold_is_refused_before_its_settings_are_made() {
        let fits = StudyFile::from_toml(&crossed(&[10, 100, 100])).unwrap();
        assert_eq!(fits.check_cross(), Ok(()));
        assert_eq!(fits.settings().len(), MAX_CROSSED_SETTINGS);
        // Eight conditions of 100 levels: 10¹⁶ combinations from under 3 kB of TOML.
        let huge = StudyFile::from_toml(&crossed(&[100; 8])).unwrap();
        let refused = huge.check_cross().unwrap_err();
        assert_eq!(
            refused,
            StudyFileError::CrossTooLarge {
                settings: 10u128.pow(16)
            }
        );
        assert!(refused.to_string().starts_with("cross: "), "{refused}");
    }
}
