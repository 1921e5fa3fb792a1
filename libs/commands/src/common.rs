//! Argument groups and value parsers shared by several commands: `--flights`, `--max-broadcasts` and `--frame-check`, `--sensor-preset`/`--perturb`, `--render`, `--jobs`, `--payload`, `--viewpoint`, where a recorded or live camera was (`--viewpoint`/`--observer`), `--policy` and an observer's plug-in receiver (`--receiver O2=python:M:C`).

use anyhow::Result;
use proto::scene::Placement;
use serde::{Deserialize, Serialize};

/// `--flights sequential|concurrent` and `--max-broadcasts N`, overriding a case's own, shared
/// by the commands that fly a whole case.
/// The frame check of one observer's broadcast, for the commands that decode without a case
/// (`link`, `decode`, `observe`).
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct FrameCheckArg {
    /// The check every frame carries after its six payload bits: `none` (the paper), `parity`
    /// or `crc3`; a frame that fails it is never released.
    #[arg(
        long = "frame-check",
        value_enum,
        value_name = "CHECK",
        default_value_t
    )]
    pub frame_check: proto::FrameCheck,
}

#[derive(Debug, Clone, Copy, clap::Args)]
pub struct CaseOverrides {
    /// Safety router, overriding the case's `flights`: `sequential` flies one trip at a time
    /// (the paper), `concurrent` lets trips overlap when their reserved space-time paths keep
    /// the 0.4 m clearance.
    #[arg(long = "flights", value_enum)]
    pub mode: Option<proto::FlightMode>,
    /// Broadcasts a round may fly, overriding the case's `max_broadcasts`: the round's offers
    /// flown again while a live observer has not decided (1, the paper: one broadcast).
    #[arg(long = "max-broadcasts", value_name = "N",
          value_parser = clap::value_parser!(u32).range(1..=proto::sched::MAX_ROUND_BROADCASTS as i64))]
    pub max_broadcasts: Option<u32>,
    /// The check every frame carries after its six payload bits, overriding the case's
    /// `frame_check` (with --link: the broadcast's): `none` (the paper), `parity` or `crc3`;
    /// a frame that fails it is never released.
    #[arg(long = "frame-check", value_enum, value_name = "CHECK")]
    pub frame_check: Option<proto::FrameCheck>,
}

/// `--sensor-preset NAME` and `--perturb KEY=VALUE…`, shared by the commands that perturb.
#[derive(Debug, Clone, clap::Args)]
pub struct PerturbArgs {
    /// A named sensor preset (`v2e-clean`, `v2e-default`, `v2e-noisy`, `dvs-dim`) or a preset
    /// file (`waggle sensor-fit --out`; any value with `.` or `/`): its `events.*` terms, under
    /// any --perturb given too. None: the paper's ideal sensors.
    #[arg(long = "sensor-preset", value_name = "NAME")]
    pub sensor_preset: Option<String>,
    /// A perturbation term KEY=VALUE (repeatable; `waggle trials --help` lists them).
    #[arg(long = "perturb", value_name = "KEY=VALUE")]
    pub perturb: Vec<String>,
}

/// Where a recorded or live camera was (`waggle decode`, `waggle observe`).
#[derive(Debug, Clone, clap::Args)]
pub struct CameraPlaceArgs {
    /// Where the camera was: AZIMUTH_DEG,ELEVATION_DEG,DISTANCE_M from the performer's hover
    /// point (as `waggle link --viewpoint`).
    #[arg(long, value_name = "AZ,EL,DIST", value_parser = parse_viewpoint, allow_hyphen_values = true, conflicts_with = "observer")]
    pub viewpoint: Option<Placement>,
    /// Or: the camera was observer OBSERVER (e.g. O2) of the built-in formation of --observers.
    #[arg(long)]
    pub observer: Option<String>,
    /// Size of the built-in formation --observer refers to.
    #[arg(long, default_value_t = 3)]
    pub observers: usize,
}

/// `--render raster|damage|full`, shared by every command that renders cameras.
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct RenderArg {
    /// How cameras render: `raster` (the default) is Waggle's CPU renderer (no GL; only the
    /// moved bodies' rectangle, each body at a level of detail for its size); `damage` (alias
    /// `mujoco`) is MuJoCo's renderer, the paper's, redrawing only what moved since a camera's
    /// last frame, `full` MuJoCo's renderer redrawing every pixel (byte-identical to `damage`).
    #[arg(long = "render", value_enum, default_value_t)]
    pub path: proto::RenderPath,
}

/// `--receiver OBSERVER=python:MODULE:CLASS…` and its time limit, shared by the commands that
/// run a whole mission (`mission`, `run`, `compose`, `up`).
#[derive(Debug, Clone, clap::Args)]
pub struct MissionReceiversArg {
    /// Give one observer a receiver of your own: `O2=python:MODULE:CLASS`, a Python class
    /// following one of the plug-in protocols (`waggle.plugin`: tracker, tokens or full), run
    /// in a worker process of its own on `WAGGLE_PYTHON` (default `python3`) and fed only that
    /// observer's sensor. Repeat for other observers. A plug-in that raises, returns malformed
    /// output or runs past its time limit leaves its observer deaf for the rest of the mission,
    /// and the failure is reported by name.
    #[arg(long = "receiver", value_name = "OBSERVER=python:MODULE:CLASS",
          value_parser = parse_observer_plugin)]
    pub receivers: Vec<receiver_plugin::ObserverPlugin>,
    /// Wall-clock limit of a plug-in receiver over the whole mission, seconds (an hour by
    /// default: a long mission on a busy machine is not a hung plug-in).
    #[arg(long = "plugin-time-limit-s", value_name = "SECONDS", default_value_t = 3600.0,
          value_parser = parse_time_limit, requires = "receivers")]
    pub plugin_time_limit_s: f64,
}

impl MissionReceiversArg {
    /// The receivers, refusing an observer named twice.
    pub fn checked(&self) -> anyhow::Result<Vec<receiver_plugin::ObserverPlugin>> {
        let mut seen = std::collections::BTreeSet::new();
        for r in &self.receivers {
            if !seen.insert(&r.observer) {
                anyhow::bail!("--receiver names {} more than once", r.observer.as_str());
            }
        }
        Ok(self.receivers.clone())
    }

    /// The plug-ins' time limit (`None` when no observer has one).
    pub fn time_limit(&self) -> Option<std::time::Duration> {
        (!self.receivers.is_empty())
            .then(|| std::time::Duration::from_secs_f64(self.plugin_time_limit_s))
    }
}

/// A plug-in's wall-clock time limit, seconds.
pub(crate) fn parse_time_limit(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v <= 86_400.0 => Ok(v),
        _ => Err(format!(
            "{s:?} is not a time limit in seconds (0 < SECONDS ≤ 86400)"
        )),
    }
}

fn parse_observer_plugin(s: &str) -> Result<receiver_plugin::ObserverPlugin, String> {
    s.parse()
        .map_err(|e: receiver_plugin::PluginError| e.to_string())
}

impl CaseOverrides {
    /// `case` with the overrides applied.
    pub fn apply(self, mut case: run_format::case::Case) -> run_format::case::Case {
        if let Some(mode) = self.mode {
            case.flights = mode;
        }
        if let Some(n) = self.max_broadcasts {
            case.max_broadcasts = n;
        }
        if let Some(c) = self.frame_check {
            case.frame_check = c;
        }
        case
    }
}

impl PerturbArgs {
    /// The preset's terms, then every --perturb over them.
    pub fn perturbation(&self) -> anyhow::Result<perturb::Perturbation> {
        sensor_perturbation(self.sensor_preset.as_deref(), &self.perturb)
    }
}

/// The terms of `preset` — a built-in preset's name or a preset file's path — then
/// `assignments` over them.
pub fn sensor_perturbation<S: AsRef<str>>(
    preset: Option<&str>,
    assignments: &[S],
) -> anyhow::Result<perturb::Perturbation> {
    Ok(node_args::preset_perturbation(preset, assignments)?)
}

/// `--jobs N`: a whole number of at least 1 (0 used to run one job without a word).
pub fn parse_jobs(s: &str) -> Result<usize, String> {
    match s.trim().parse::<usize>() {
        Ok(0) => Err("must be at least 1: 0 jobs would run nothing".to_owned()),
        Ok(jobs) => Ok(jobs),
        Err(e) => Err(format!("not a whole number of jobs ({e})")),
    }
}

/// Parses exactly six characters of '0'/'1' into a number, b1 most significant.
pub fn parse_bits6(s: &str) -> Result<u8, String> {
    if s.len() != 6 || !s.bytes().all(|b| b == b'0' || b == b'1') {
        return Err(format!(
            "payload {s:?} is not six binary digits (e.g. 011010)"
        ));
    }
    u8::from_str_radix(s, 2).map_err(|e| e.to_string())
}

/// Parses `AZIMUTH_DEG,ELEVATION_DEG,DISTANCE_M` into an aimed placement.
pub fn parse_viewpoint(s: &str) -> Result<Placement, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let [az, el, d] = parts[..] else {
        return Err(format!(
            "viewpoint {s:?} is not AZIMUTH_DEG,ELEVATION_DEG,DISTANCE_M (e.g. 40,0,1.3)"
        ));
    };
    let num = |v: &str, what: &str| -> Result<f64, String> {
        v.parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("viewpoint {s:?}: {what} {v:?} is not a finite number"))
    };
    let (az, el, d) = (
        num(az, "azimuth")?,
        num(el, "elevation")?,
        num(d, "distance")?,
    );
    if !(-85.0..=85.0).contains(&az) || !(-60.0..=60.0).contains(&el) {
        return Err(format!(
            "viewpoint {s:?}: azimuth must be within ±85° and elevation within ±60°"
        ));
    }
    if !(0.6..=10.0).contains(&d) {
        return Err(format!(
            "viewpoint {s:?}: distance must be 0.6–10 m (the performer gestures ±0.2 m)"
        ));
    }
    Ok(Placement::viewpoint(az, el, d))
}

/// How observers chose their tasks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Policy {
    /// Waggle: each observer decodes the performer's broadcast and allocates locally.
    #[default]
    Waggle,
    /// No communication: observer i always takes offer site i mod (number of sites), decided
    /// when each round's broadcast starts, without reading it (the fixed-allocation baseline).
    Fixed,
}

impl std::fmt::Display for Policy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Policy::Waggle => "waggle",
            Policy::Fixed => "fixed",
        })
    }
}

#[cfg(test)]
mod tests {
    use crate::common::parse_jobs;

    #[test]
    fn jobs_must_be_a_whole_number_of_at_least_one() {
        assert_eq!(parse_jobs("1"), Ok(1));
        assert_eq!(parse_jobs("16"), Ok(16));
        for bad in ["0", "-1", "two", "", "1.5"] {
            assert!(parse_jobs(bad).is_err(), "{bad:?} accepted");
        }
        assert!(parse_jobs("0").unwrap_err().contains("at least 1"));
    }
}
