//! `waggle trials`: one condition, N seeded trials under a perturbation.

use crate::common::{Policy, parse_bits6, parse_viewpoint};
use clap::Args;
use proto::scene::Placement;
use proto::{Receiver, Rectification};
use std::path::PathBuf;

#[derive(Debug, Args)]
#[command(after_long_help = perturbation_help())]
pub struct TrialsArgs {
    /// The broadcast: six-bit payloads flown back to back, comma-separated (e.g. 011010,100111).
    #[arg(long, value_delimiter = ',', value_parser = parse_bits6,
          required_unless_present = "case", conflicts_with = "case")]
    pub link: Vec<u8>,
    /// Instead of a link: a whole case (built-in name or TOML file), flown in one process per
    /// trial; success is the case's expected outcome.
    #[arg(long)]
    pub case: Option<String>,
    /// Whole missions only: overrides of the case's `flights` and `max_broadcasts`.
    #[command(flatten)]
    pub overrides: crate::common::CaseOverrides,
    /// Whole missions only: `waggle` or the `fixed` no-communication baseline.
    #[arg(long, value_enum, default_value_t, requires = "case")]
    pub policy: Policy,
    /// Number of observers in the built-in formation (1..=8).
    #[arg(long, default_value_t = 3)]
    pub observers: usize,
    /// Place observers at AZIMUTH_DEG,ELEVATION_DEG,DISTANCE_M instead (repeat, up to 8).
    #[arg(long = "viewpoint", value_name = "AZ,EL,DIST", value_parser = parse_viewpoint, allow_hyphen_values = true)]
    pub viewpoints: Vec<Placement>,
    /// The observers' sensor (`ideal`, the ground-truth receiver, for --case only).
    #[arg(long, value_enum)]
    pub modality: Receiver,
    /// Number of trials.
    #[arg(long, default_value_t = 100)]
    pub trials: u64,
    /// Seed of the run: trial k draws from a seed derived from it and k.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    #[command(flatten)]
    pub perturb: crate::common::PerturbArgs,
    /// A real camera's background laid over the event sensor's noise: a recording `waggle
    /// decode --events` reads, or PACKAGE/FILE for one setup fetched into
    /// `third_party/PACKAGE/data/` (`faery/evt3.raw`). `events.real_noise_copies` scales it,
    /// `events.real_noise_fitted=1` swaps it for the model fitted from it.
    #[arg(long = "real-noise", value_name = "FILE", conflicts_with = "case")]
    pub real_noise: Option<String>,
    /// The stretch of --real-noise where nothing moved, START_S:END_S from its first event
    /// (default: its events with no neighbour within 10 ms).
    #[arg(long = "real-noise-static", value_name = "START_S:END_S",
          value_parser = crate::sensor_fit::parse_window, requires = "real_noise")]
    pub real_noise_static: Option<(f64, f64)>,
    /// Trials at once (threads; default: the machine's cores).
    #[arg(long, value_parser = crate::common::parse_jobs)]
    pub jobs: Option<usize>,
    /// Fly the acquisition sweep before the first offer: `true` or `false` (default: only for
    /// event cameras, as in the paper).
    #[arg(long, value_name = "BOOL")]
    pub acquisition: Option<bool>,
    /// Viewpoint rectification of the receivers' trajectories.
    #[arg(long, value_enum, default_value_t = Rectification::default())]
    pub rectify: Rectification,
    /// A receiver of your own instead of Waggle's: `python:MODULE:CLASS`, a Python class
    /// following one of the plug-in protocols (`waggle.plugin`: tracker, tokens or full),
    /// run in worker processes (one per job) on `WAGGLE_PYTHON` (default `python3`), scored
    /// by the same trials. Link trials only.
    #[arg(long, value_name = "python:MODULE:CLASS", value_parser = parse_receiver,
          conflicts_with = "case")]
    pub receiver: Option<receiver_plugin::PluginSpec>,
    /// Wall-clock limit of one trial of a plug-in receiver, seconds: a trial past it is
    /// recorded as `timed-out` and the run marked not reproducible.
    #[arg(long = "plugin-time-limit-s", value_name = "SECONDS", default_value_t = 600.0,
          value_parser = crate::common::parse_time_limit, requires = "receiver")]
    pub plugin_time_limit_s: f64,
    #[command(flatten)]
    pub render: crate::common::RenderArg,
    #[command(flatten)]
    pub shard: crate::shard::ShardArgs,
    #[command(flatten)]
    pub render_cache: crate::shard::RenderCacheArg,
    /// Output directory: trials.json (deterministic), cost.json (wall-clock figures) and the
    /// per-trial records under trials/. Rerun into the same directory to resume: only trials
    /// not recorded run.
    #[arg(long)]
    pub out: PathBuf,
}

fn parse_receiver(s: &str) -> Result<receiver_plugin::PluginSpec, String> {
    s.parse()
        .map_err(|e: receiver_plugin::PluginError| e.to_string())
}

fn perturbation_help() -> String {
    let mut s = String::from("Perturbation terms (--perturb KEY=VALUE; every default is off):\n");
    for p in perturb::spec::PARAMETERS {
        s.push_str(&format!(
            "  {:<28} [{}] default {}: {}\n",
            p.key, p.unit, p.default, p.doc
        ));
    }
    s.push_str("\nSensor presets (--sensor-preset NAME; --perturb terms override them):\n");
    for preset in perturb::preset::PRESETS {
        let terms: Vec<String> = preset
            .terms
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect();
        s.push_str(&format!(
            "  {:<12} {} [{}]\n",
            preset.name,
            terms.join(" "),
            preset.source
        ));
        if !preset.unmodelled.is_empty() {
            s.push_str(&format!(
                "               not modelled yet: {}\n",
                preset.unmodelled
            ));
        }
    }
    s
}
