//! The event cameras' sensor model of a session run as processes (`waggle run`/`compose`
//! `--sensor-preset NAME --perturb events.KEY=VALUE --seed S`): a named preset and `events.*`
//! terms over it, handed to every camera process as its own arguments (`sim-node camera
//! --sensor-preset … --perturb … --seed …`), which re-parses them with the same
//! [`perturb::Perturbation::with_preset`] and seeds observer i's sensor with
//! `stream_seed(seed, Stream::EventSensor, i)` — the sensors `waggle mission` builds.
//!
//! No preset and no term: no argument at all, so such a session's nodes and outputs are the
//! ones it always had.

use anyhow::{Context, Result, bail};
use perturb::Perturbation;
use proto::Modality;

use crate::run_dir::SensorRecord;

/// The camera arguments that carry the sensor model.
const PRESET_ARG: &str = "--sensor-preset";
const PERTURB_ARG: &str = "--perturb";
const SEED_ARG: &str = "--seed";

/// A session's event-sensor model as given on the command line.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SensorSpec {
    /// A named preset (`perturb::preset::PRESETS`).
    pub preset: Option<String>,
    /// `events.KEY=VALUE` terms over the preset's, in the order given (later ones win).
    pub perturb: Vec<String>,
    /// The run's seed of the sensors' noise draws.
    pub seed: u64,
}

impl SensorSpec {
    /// True when the sensors are the paper's ideal ones (nothing to hand on).
    pub fn is_none(&self) -> bool {
        self.preset.is_none() && self.perturb.is_empty()
    }

    /// The perturbation the preset and terms make, refusing an unknown preset or term (naming
    /// it and the known ones) and any term outside the `events` group: a camera process models
    /// the event sensor only (`rgb.*`, `link.*`, `geometry.*` and `flight.*` terms are modelled
    /// by `waggle trials` and `waggle mission`).
    pub fn perturbation(&self) -> Result<Perturbation> {
        let p = Perturbation::with_preset(self.preset.as_deref(), &self.perturb)
            .context("--sensor-preset/--perturb")?;
        for a in &self.perturb {
            let key = a.split_once('=').map_or(a.as_str(), |(k, _)| k).trim();
            if !key.starts_with("events.") {
                bail!(
                    "--perturb {a}: only events.* terms apply here (the event cameras' sensor \
                     model), not {key}; `waggle trials` and `waggle mission` model the other \
                     groups"
                );
            }
        }
        Ok(p)
    }

    /// [`Self::perturbation`] for a session whose cameras carry `modality`: a sensor model on
    /// RGB cameras is refused (it would change nothing).
    pub fn check(&self, modality: Modality) -> Result<()> {
        if self.is_none() {
            return Ok(());
        }
        self.perturbation()?;
        if modality != Modality::Events {
            bail!(
                "--sensor-preset/--perturb set the event cameras' sensor model; this session's \
                 cameras are {} (use --modality events)",
                modality.as_str()
            );
        }
        Ok(())
    }

    /// A camera's arguments carrying this model (none when [`Self::is_none`]).
    pub fn camera_args(&self) -> Vec<String> {
        if self.is_none() {
            return Vec::new();
        }
        let mut a = Vec::new();
        if let Some(p) = &self.preset {
            a.extend([PRESET_ARG.to_string(), p.clone()]);
        }
        for t in &self.perturb {
            a.extend([PERTURB_ARG.to_string(), t.clone()]);
        }
        a.extend([SEED_ARG.to_string(), self.seed.to_string()]);
        a
    }

    /// The model a camera's arguments carry (the inverse of [`Self::camera_args`]; other
    /// arguments are skipped).
    pub fn from_camera_args(args: &[String]) -> Result<Self> {
        let mut spec = Self::default();
        let mut it = args.iter();
        while let Some(a) = it.next() {
            let mut value = || {
                it.next()
                    .with_context(|| format!("camera argument {a} lacks its value"))
            };
            match a.as_str() {
                PRESET_ARG => spec.preset = Some(value()?.clone()),
                PERTURB_ARG => spec.perturb.push(value()?.clone()),
                SEED_ARG => {
                    let v = value()?;
                    spec.seed = v
                        .parse()
                        .with_context(|| format!("camera argument {a} {v}: not a seed"))?;
                }
                _ => {}
            }
        }
        Ok(spec)
    }

    /// What the run directory records of it (`None`: ideal sensors, nothing recorded).
    pub fn record(&self) -> Result<Option<SensorRecord>> {
        if self.is_none() {
            return Ok(None);
        }
        Ok(Some(SensorRecord {
            preset: self.preset.clone(),
            terms: self.perturb.clone(),
            perturb: self.perturbation()?.recorded(),
            seed: self.seed,
        }))
    }
}
