//! `waggle study`: a TOML file of conditions × levels × modalities, each point run as
//! `waggle trials` ([`crate::harness::trials`]), then `DIR/report.md` with the success
//! probability and its 95 % Wilson interval against each level, per modality, and a figure.
//!
//! ```toml
//! name = "event-noise"
//! modalities = ["events"]
//! link = ["011010"]
//! observers = 3              # or: viewpoint = [azimuth_deg, elevation_deg, distance_m]
//! trials = 100
//! seed = 1
//! criterion = "exact-payloads"
//! sensor_preset = "v2e-default"          # optional: a named sensor preset under `fixed`
//! fixed = { "link.drop_rate" = 0.0 }      # optional: terms held at one value
//! real_noise = "faery/evt3.raw"           # optional: a real camera's background (events)
//! rectify = "frontal"                     # optional: off | pitched (default) | frontal
//! receivers = ["waggle", "python:numpy_tracker:CentroidTracker"]   # optional: default waggle
//! [[vary]]                                # one table per condition; several allowed
//! key = "events.shot_noise_hz"            # a perturbation term, or viewpoint.azimuth_deg /
//! levels = [0.0, 0.1, 0.2, 0.5, 1.0]      # viewpoint.elevation_deg / viewpoint.distance_m,
//!                                         # or link.payload (levels: payload values, 26 = 011010)
//! ```
//! With `cross = true` the conditions are crossed (a point for every combination of their
//! levels, e.g. light × wind × viewpoint) and the report is laid out per factor: the success
//! pooled over the other factors' levels, and every combination. Otherwise each
//! condition is varied alone, the others held at their `fixed` value (or off); each gets a
//! section of the report and its figure `success-<key>.svg`. Unknown keys, unknown terms and out-of-range levels are refused at load, naming them.
//!
//! Its parts: one condition and its levels ([`vary`]), running a link study ([`run`]), the
//! merge of records into results ([`merge`]), the report and figures ([`report`], [`figure`]),
//! and the baselines study of whole missions ([`baselines`], [`baselines_run`]).

pub mod baselines;
pub mod baselines_run;
pub mod figure;
pub mod merge;
pub mod report;
pub mod run;
pub mod vary;

use std::collections::BTreeMap;

use anyhow::{Context, Result, bail};
use proto::scene::{Formation, Placement};
use proto::{Modality, Rectification, RenderPath};
use serde::{Deserialize, Serialize};

use crate::harness::flight::air::PointTracking;
use crate::harness::study::baselines::BaselineStudy;
pub use crate::harness::study::vary::Vary;
use commands::common::{parse_bits6, parse_viewpoint};

use crate::harness::trials::{PluginOptions, TrialsOptions};
use receiver_plugin::PluginSpec;

pub use run_format::study::BUILT_IN;

/// A study of either kind: seeded link trials over levels, or whole-mission baselines.
#[derive(Debug, Clone)]
pub enum Study {
    Link(Box<StudyFile>),
    Baselines(BaselineStudy),
}

/// A study's TOML text and where it came from (a built-in name or a file path).
pub fn study_text(name_or_path: &str) -> Result<(String, String)> {
    match BUILT_IN.iter().find(|(n, _)| *n == name_or_path) {
        Some((_, t)) => Ok(((*t).to_owned(), format!("built-in study {name_or_path}"))),
        None => Ok((
            std::fs::read_to_string(name_or_path).with_context(|| {
                format!(
                    "{name_or_path} is neither a built-in study ({}) nor a readable file",
                    BUILT_IN
                        .iter()
                        .map(|(n, _)| *n)
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            })?,
            name_or_path.to_owned(),
        )),
    }
}

impl Study {
    /// Reads and checks a study: a file with `arms` is a baselines study.
    pub fn load(name_or_path: &str) -> Result<Self> {
        let (text, origin) = study_text(name_or_path)?;
        let value: toml::Table =
            toml::from_str(&text).with_context(|| format!("{origin}: not valid TOML"))?;
        if value.contains_key("arms") {
            let study: BaselineStudy =
                toml::from_str(&text).with_context(|| format!("{origin}: not a valid study"))?;
            study
                .check()
                .with_context(|| format!("{origin}: invalid study"))?;
            Ok(Self::Baselines(study))
        } else {
            Ok(Self::Link(Box::new(StudyFile::load(name_or_path)?)))
        }
    }
}

pub use run_format::study_file::StudyFile;
use run_format::study_file::{LINK_PAYLOAD, level_text, payload_level};

/// One point: a modality (and receiver) at one level of one condition.
#[derive(Debug, Clone)]
pub struct Point {
    pub key: String,
    pub modality: Modality,
    /// The series the report lists it under: the modality, with the plug-in receiver if any.
    pub series: String,
    pub level: f64,
    /// Crossed studies: every condition's level at this point (empty otherwise).
    pub factors: BTreeMap<String, f64>,
    /// Its directory name under the study's output.
    pub dir: String,
    pub options: TrialsOptions,
}

/// The key of every point of a crossed study: its conditions joined (`light.lux × link.drop_rate`).
pub fn cross_key(study: &StudyFile) -> String {
    study
        .vary
        .iter()
        .map(|v| v.key.as_str())
        .collect::<Vec<_>>()
        .join(" × ")
}

/// The measured point as the report lists it.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct PointResult {
    pub key: String,
    pub modality: String,
    pub level: f64,
    /// Crossed studies: every condition's level at this point.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub factors: BTreeMap<String, f64>,
    pub trials: u64,
    pub successes: u64,
    pub success_rate: Option<f64>,
    pub ci95: [f64; 2],
    pub dir: String,
    /// Messages released over every trial and observer (decoded).
    pub decoded_messages: u64,
    /// Sensor messages (frames or event packets, one per 40 ms) over every trial and observer.
    pub sensor_messages: u64,
    /// Events received over every trial and observer (0 for RGB).
    pub events: u64,
    /// Points whose trials fly their own flights: the performer's tracking over them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tracking: Option<PointTracking>,
}

impl PointResult {
    /// The success probability and its interval as printed (`0.610`, `[0.512, 0.700]`).
    pub fn rate_cells(&self) -> (String, String) {
        (
            self.success_rate.map_or("—".into(), |p| format!("{p:.3}")),
            format!("[{:.3}, {:.3}]", self.ci95[0], self.ci95[1]),
        )
    }
}

const VIEWPOINT_AXES: [&str; 3] = [
    "viewpoint.azimuth_deg",
    "viewpoint.elevation_deg",
    "viewpoint.distance_m",
];

/// What the lab makes of a study file: it loads one, and turns it into points with their
/// perturbations, formations and receivers (the checks that need the simulator's terms, a
/// real-noise file or a plug-in's name).
pub trait StudyPlan: Sized {
    /// Reads a link study from a built-in name or a file path, checking every field.
    fn load(name_or_path: &str) -> Result<Self>;
    /// The series of the study's points, in report order: each modality, with each receiver.
    fn series(&self) -> Vec<String>;
    /// Every point of the study, checked, in the study's order (condition, level, modality).
    fn points(&self, render: RenderPath, jobs: usize) -> Result<Vec<Point>>;
}

impl StudyPlan for StudyFile {
    fn load(name_or_path: &str) -> Result<Self> {
        let (text, origin) = study_text(name_or_path)?;
        let study: Self =
            toml::from_str(&text).with_context(|| format!("{origin}: not a valid study"))?;
        study
            .points(RenderPath::default(), 1)
            .with_context(|| format!("{origin}: invalid study"))?;
        Ok(study)
    }

    fn series(&self) -> Vec<String> {
        let receivers = receivers(self).unwrap_or_default();
        self.modalities
            .iter()
            .flat_map(|&m| receivers.iter().map(move |r| series_label(m, r.as_ref())))
            .collect()
    }

    fn points(&self, render: RenderPath, jobs: usize) -> Result<Vec<Point>> {
        self.check_shape()?;
        let payloads = self
            .link
            .iter()
            .map(|p| parse_bits6(p).map_err(anyhow::Error::msg))
            .collect::<Result<Vec<u8>>>()
            .context("link")?;
        let mut base =
            commands::common::sensor_perturbation::<&str>(self.sensor_preset.as_deref(), &[])
                .context("sensor_preset")?;
        for (k, v) in &self.fixed {
            base.set(k, *v).context("fixed")?;
        }
        if let Some(spec) = &self.real_noise {
            let window = self.real_noise_static.map(|[a, b]| (a, b));
            let source =
                crate::harness::decode::real_noise::load(spec, window).context("real_noise")?;
            base = base.with_real_noise(source);
        } else if self.real_noise_static.is_some() {
            bail!("real_noise_static needs real_noise");
        }
        let rectification = match &self.rectify {
            Some(r) => <Rectification as clap::ValueEnum>::from_str(r, true)
                .map_err(|e| anyhow::anyhow!("rectify {r:?}: {e}"))?,
            None => Rectification::default(),
        };
        self.check_cross()?;
        let (receivers, trial_limit) = (receivers(self)?, self.trial_limit()?);
        let mut points = Vec::new();
        for setting in self.settings() {
            for (&modality, receiver) in self
                .modalities
                .iter()
                .flat_map(|m| receivers.iter().map(move |r| (m, r)))
            {
                let mut perturbation = base.clone();
                let mut axes = Vec::new();
                let mut point_payloads = payloads.clone();
                for &(key, level) in &setting {
                    if VIEWPOINT_AXES.contains(&key) {
                        axes.push((key, level));
                    } else if key == LINK_PAYLOAD {
                        point_payloads = vec![payload_level(level).with_context(|| {
                            format!(
                                "vary {LINK_PAYLOAD}: level {level} is not a six-bit payload's \
                                 value (an integer 0-63; 26 is 011010)"
                            )
                        })?];
                    } else {
                        perturbation.set(key, level).context("vary")?;
                    }
                }
                perturbation.check().context("vary")?;
                perturbation.check_real_noise().context("vary")?;
                let formation = formation(self, &axes)?;
                let (key, level) = setting[0];
                // A plug-in's points sit beside Waggle's, named by its class.
                let modality_dir = receiver
                    .as_ref()
                    .map_or(modality.to_string(), |r| format!("{modality}-{}", r.class));
                let dir = if self.cross {
                    let parts: Vec<String> = setting
                        .iter()
                        .map(|(k, l)| format!("{k}-{}", level_label(k, *l)))
                        .collect();
                    format!("{modality_dir}-{}", parts.join("-"))
                } else if self.vary.len() == 1 {
                    format!("{modality_dir}-{}", level_label(key, level))
                } else {
                    format!("{modality_dir}-{key}-{}", level_label(key, level))
                };
                points.push(Point {
                    key: if self.cross {
                        cross_key(self)
                    } else {
                        key.to_owned()
                    },
                    modality,
                    series: series_label(modality, receiver.as_ref()),
                    level,
                    factors: if self.cross {
                        setting.iter().map(|(k, l)| ((*k).to_owned(), *l)).collect()
                    } else {
                        BTreeMap::new()
                    },
                    dir,
                    options: TrialsOptions {
                        payloads: point_payloads,
                        formation,
                        modality,
                        trials: self.trials,
                        seed: self.seed,
                        perturbation,
                        jobs,
                        render,
                        rectification,
                        // One flight for every modality of the study (matched trajectories).
                        acquisition: Some(self.modalities.contains(&Modality::Events)),
                        plugin: receiver.clone().map(|spec| PluginOptions {
                            spec,
                            trial_limit: Some(trial_limit),
                        }),
                        frame_check: proto::FrameCheck::None,
                    },
                });
            }
        }
        Ok(points)
    }
}

/// The formation of a point whose viewpoint axes are at `axes`.
fn formation(study: &StudyFile, axes: &[(&str, f64)]) -> Result<Formation> {
    match (study.observers, study.viewpoint) {
        (Some(_), Some(_)) => bail!("give either observers or viewpoint, not both"),
        (Some(n), None) => {
            if let Some((key, _)) = axes.first() {
                bail!("vary.key {key} needs viewpoint = [az, el, dist]");
            }
            Formation::standard(n).map_err(|_| anyhow::anyhow!("observers = {n} is outside 1..=8"))
        }
        (None, Some(mut v)) => {
            for (key, level) in axes {
                let k = VIEWPOINT_AXES.iter().position(|a| a == key).unwrap_or(0);
                v[k] = *level;
            }
            let what = axes.iter().map(|a| a.0).collect::<Vec<_>>().join(", ");
            let p: Placement =
                parse_viewpoint(&format!("{},{},{}", v[0], v[1], v[2])).map_err(|e| {
                    anyhow::anyhow!("{}: {e}", if what.is_empty() { "viewpoint" } else { &what })
                })?;
            Ok(Formation::custom(vec![p])?)
        }
        (None, None) => bail!("give observers = N or viewpoint = [az, el, dist]"),
    }
}

/// The receivers of each modality's points: `None` is Waggle's own.
fn receivers(study: &StudyFile) -> Result<Vec<Option<PluginSpec>>> {
    if study.receivers.is_empty() {
        return Ok(vec![None]);
    }
    let mut out = Vec::new();
    for r in &study.receivers {
        let receiver = match r.as_str() {
            "waggle" => None,
            _ => Some(r.parse::<PluginSpec>().context("receivers")?),
        };
        if out.contains(&receiver) {
            bail!("receivers: {r} is listed twice");
        }
        out.push(receiver);
    }
    Ok(out)
}

/// A series' label: the modality, and the plug-in receiver when it is not Waggle's.
fn series_label(modality: Modality, receiver: Option<&PluginSpec>) -> String {
    match receiver {
        None => modality.to_string(),
        Some(spec) => format!("{modality} · {spec}"),
    }
}

/// A level as a directory-name fragment (`0.5` → `0.5`, `-20` → `m20`, payload `26` →
/// `011010`).
fn level_label(key: &str, level: f64) -> String {
    level_text(key, level).replace('-', "m")
}

/// The figure of condition `key`: `success-<key>.svg`.
pub fn figure_name(key: &str) -> String {
    format!("success-{key}.svg")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<StudyFile> {
        let s: StudyFile = toml::from_str(text)?;
        s.points(RenderPath::default(), 1)?;
        Ok(s)
    }

    const GOOD: &str = r#"
name = "t"
modalities = ["events", "rgb"]
link = ["011010"]
observers = 2
trials = 10
criterion = "exact-payloads"
[[vary]]
key = "events.shot_noise_hz"
levels = [0.0, 0.5]
"#;

    #[test]
    fn a_good_study_has_a_point_per_modality_and_level() {
        let s = parse(GOOD).unwrap();
        let pts = s.points(RenderPath::default(), 1).unwrap();
        assert_eq!(pts.len(), 4);
        assert_eq!(pts[2].dir, "events-0.5");
        assert_eq!(pts[2].options.perturbation.get("events.shot_noise_hz"), 0.5);
        assert!(pts.iter().all(|p| p.options.acquisition == Some(true)));
    }

    #[test]
    fn several_conditions_are_varied_one_at_a_time() {
        let text =
            format!("{GOOD}\n[[vary]]\nkey = \"link.drop_rate\"\nlevels = [0.1, 0.2, 0.3]\n");
        let pts = parse(&text)
            .unwrap()
            .points(RenderPath::default(), 1)
            .unwrap();
        assert_eq!(pts.len(), 2 * (2 + 3));
        let drop = pts
            .iter()
            .filter(|p| p.key == "link.drop_rate")
            .collect::<Vec<_>>();
        assert_eq!(drop.len(), 6);
        assert!(
            drop.iter()
                .all(|p| p.options.perturbation.get("events.shot_noise_hz") == 0.0)
        );
        assert_eq!(drop[0].dir, "events-link.drop_rate-0.1");
        let dirs: std::collections::BTreeSet<&str> = pts.iter().map(|p| p.dir.as_str()).collect();
        assert_eq!(dirs.len(), pts.len(), "directory names collide");
    }

    #[test]
    fn crossed_conditions_give_every_combination() {
        let text = format!(
            "cross = true\n{GOOD}\n[[vary]]\nkey = \"link.drop_rate\"\nlevels = [0.1, 0.2, 0.3]\n"
        );
        let pts = parse(&text)
            .unwrap()
            .points(RenderPath::default(), 1)
            .unwrap();
        assert_eq!(pts.len(), 2 * 2 * 3);
        let dirs: std::collections::BTreeSet<&str> = pts.iter().map(|p| p.dir.as_str()).collect();
        assert_eq!(dirs.len(), pts.len(), "directory names collide");
        let last = pts.last().unwrap();
        assert_eq!(last.dir, "rgb-events.shot_noise_hz-0.5-link.drop_rate-0.3");
        assert_eq!(last.options.perturbation.get("events.shot_noise_hz"), 0.5);
        assert_eq!(last.options.perturbation.get("link.drop_rate"), 0.3);
        assert_eq!(last.factors.len(), 2);
        // The study as run.json records it reads back the same.
        let study = parse(&text).unwrap();
        let back: StudyFile = toml::from_str(&toml::to_string(&study).unwrap()).unwrap();
        assert!(back.cross);
        let twice = text.replace("link.drop_rate", "events.shot_noise_hz");
        assert!(format!("{:#}", parse(&twice).unwrap_err()).contains("different condition"));
    }

    #[test]
    fn a_payload_condition_gives_each_point_its_own_broadcast() {
        let text = GOOD
            .replace("observers = 2", "viewpoint = [0.0, 0.0, 1.5]")
            .replace("events.shot_noise_hz\"", "link.payload\"")
            .replace("[0.0, 0.5]", "[26.0, 39.0]")
            + "[[vary]]\nkey = \"viewpoint.azimuth_deg\"\nlevels = [0.0, 20.0]\n";
        let text = text.replace("criterion", "cross = true\ncriterion");
        let study = parse(&text).unwrap();
        let header = report::report(&study, &[]);
        assert!(
            header.contains("Broadcast each point's `link.payload`"),
            "{header}"
        );
        let pts = study.points(RenderPath::default(), 1).unwrap();
        assert_eq!(pts.len(), 2 * 2 * 2);
        let events: Vec<_> = pts
            .iter()
            .filter(|p| p.modality == Modality::Events)
            .collect();
        assert_eq!(events[0].options.payloads, vec![0b011010]);
        assert_eq!(events[3].options.payloads, vec![0b100111]);
        assert_eq!(
            events[3].dir,
            "events-link.payload-100111-viewpoint.azimuth_deg-20"
        );
        // Not a six-bit value: refused, naming the condition and the level.
        for bad in ["[26.0, 64.0]", "[26.5]", "[-1.0]"] {
            let e = format!(
                "{:#}",
                parse(&text.replace("[26.0, 39.0]", bad)).unwrap_err()
            );
            assert!(e.contains("link.payload") && e.contains("six-bit"), "{e}");
        }
    }

    #[test]
    fn unknown_keys_and_negative_levels_are_named() {
        let e = parse(&GOOD.replace("trials = 10", "trials = 10\ntrails = 3")).unwrap_err();
        assert!(format!("{e:#}").contains("trails"), "{e:#}");
        let e =
            parse(&GOOD.replace("events.shot_noise_hz\"", "events.shot_noize_hz\"")).unwrap_err();
        assert!(format!("{e:#}").contains("events.shot_noize_hz"), "{e:#}");
        let e = parse(&GOOD.replace("[0.0, 0.5]", "[0.0, -0.5]")).unwrap_err();
        assert!(
            format!("{e:#}").contains("-0.5") && format!("{e:#}").contains("events.shot_noise_hz"),
            "{e:#}"
        );
        let e =
            parse(&GOOD.replace("trials = 10", "trials = 10\nrectify = \"sideways\"")).unwrap_err();
        assert!(format!("{e:#}").contains("sideways"), "{e:#}");
        let ok = parse(&GOOD.replace("trials = 10", "trials = 10\nrectify = \"frontal\"")).unwrap();
        let pts = ok.points(RenderPath::default(), 1).unwrap();
        assert!(
            pts.iter()
                .all(|p| p.options.rectification == Rectification::Frontal)
        );
        let e = parse(&GOOD.replace("exact-payloads", "most")).unwrap_err();
        assert!(format!("{e:#}").contains("most"), "{e:#}");
        let e = parse(&GOOD.replace("trials = 10", "trials = 10\nsensor_preset = \"v2e-loud\""))
            .unwrap_err();
        assert!(format!("{e:#}").contains("v2e-loud"), "{e:#}");
        // Out of the term's range, and in range alone but too dark for the event sensor's
        // model: both refused before anything flies, naming the level.
        for (levels, says) in [
            ("[500.0, 200000.0]", "200000"),
            ("[500.0, 0.001]", "light.lux = 0.001"),
        ] {
            let dark = GOOD
                .replace("events.shot_noise_hz\"", "light.lux\"")
                .replace("[0.0, 0.5]", levels);
            let e = format!("{:#}", parse(&dark).unwrap_err());
            assert!(e.contains("light.lux") && e.contains(says), "{e}");
        }
    }

    #[test]
    fn the_light_study_darkens_both_cameras_together() {
        let Study::Link(study) = Study::load("light").unwrap() else {
            panic!("light is a link study");
        };
        let pts = study.points(RenderPath::default(), 1).unwrap();
        let mut last: Option<(f64, u32, f64, f64)> = None;
        for p in pts.iter().filter(|p| p.modality == Modality::Events) {
            let lux = p.options.perturbation.lux();
            let rgb = pts
                .iter()
                .find(|q| q.modality == Modality::Rgb && q.level == p.level)
                .unwrap()
                .options
                .perturbation
                .rgb();
            assert_eq!(rgb.lux, lux);
            let noise = p.options.perturbation.event_noise(1);
            if let Some((prev_lux, blur, cutoff, shot)) = last {
                assert!(lux < prev_lux);
                assert!(rgb.blur_renders >= blur);
                assert!(noise.cutoff_hz < cutoff && noise.shot_noise_hz > shot);
            }
            last = Some((lux, rgb.blur_renders, noise.cutoff_hz, noise.shot_noise_hz));
        }
    }

    #[test]
    fn real_noise_terms_and_a_stretch_without_a_source_are_refused() {
        let e = parse(&GOOD.replace("trials = 10", "trials = 10\nreal_noise_static = [0.0, 1.0]"))
            .unwrap_err();
        assert!(
            format!("{e:#}").contains("real_noise_static needs real_noise"),
            "{e:#}"
        );
        let e = parse(&GOOD.replace(
            "trials = 10",
            "trials = 10\nfixed = { \"events.real_noise_copies\" = 4.0 }",
        ))
        .unwrap_err();
        assert!(
            format!("{e:#}").contains("needs a real-noise source"),
            "{e:#}"
        );
        let e = parse(&GOOD.replace("trials = 10", "trials = 10\nreal_noise = \"nope/x.raw\""))
            .unwrap_err();
        assert!(format!("{e:#}").contains("nope/x.raw"), "{e:#}");
    }

    #[test]
    fn a_sensor_preset_is_the_base_of_every_point_under_fixed_and_vary() {
        let with = GOOD.replace("trials = 10", "trials = 10\nsensor_preset = \"v2e-noisy\"");
        let pts = parse(&with)
            .unwrap()
            .points(RenderPath::default(), 1)
            .unwrap();
        for p in &pts {
            assert_eq!(p.options.perturbation.get("events.leak_hz"), 0.1);
            assert_eq!(p.options.perturbation.get("events.threshold"), 0.2);
        }
        // The varied term overrides the preset's value at each level.
        let shot: Vec<f64> = pts
            .iter()
            .map(|p| p.options.perturbation.get("events.shot_noise_hz"))
            .collect();
        assert!(shot.contains(&0.5), "{shot:?}");
    }

    #[test]
    fn every_built_in_study_loads() {
        for (name, _) in BUILT_IN {
            let study = Study::load(name).unwrap_or_else(|e| panic!("{name}: {e:#}"));
            let missions = ["baselines", "wind"].contains(name);
            assert_eq!(missions, matches!(study, Study::Baselines(_)), "{name}");
        }
    }

    #[test]
    fn viewpoint_axes_move_the_single_observer() {
        let text = GOOD
            .replace("observers = 2", "viewpoint = [0.0, 0.0, 1.3]")
            .replace("events.shot_noise_hz", "viewpoint.azimuth_deg")
            .replace("[0.0, 0.5]", "[0.0, 40.0]");
        let s = parse(&text).unwrap();
        let pts = s.points(RenderPath::default(), 1).unwrap();
        assert_ne!(
            pts[0].options.formation.placements()[0],
            pts[2].options.formation.placements()[0]
        );
        // Both modalities of a level share its formation (and so its flight).
        assert_eq!(
            pts[0].options.formation.placements()[0],
            pts[1].options.formation.placements()[0]
        );
        assert!(pts[2].options.perturbation.is_none());
        let bad = text.replace("[0.0, 40.0]", "[0.0, 120.0]");
        assert!(format!("{:#}", parse(&bad).unwrap_err()).contains("azimuth"));
    }
}
