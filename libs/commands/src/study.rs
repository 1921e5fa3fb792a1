//! `waggle study`: a study file's conditions × levels × modalities as seeded trials, and the merge of its shards.

use clap::Args;
use std::path::PathBuf;

#[derive(Debug, Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct StudyArgs {
    #[command(subcommand)]
    pub command: Option<StudyCommand>,
    #[arg(required = true, help = study_arg_help())]
    pub study: Option<String>,
    /// Output directory: one subdirectory per point (trials.json, cost.json, the per-trial
    /// records under trials/), study.json, success-<condition>.svg, report.md, cost.md. Rerun
    /// into the same directory to resume: only trials not recorded run.
    #[arg(long, required_unless_present = "print")]
    pub out: Option<PathBuf>,
    /// Trials at once (threads; default: the machine's cores).
    #[arg(long, value_parser = crate::common::parse_jobs)]
    pub jobs: Option<usize>,
    /// Override the study's trials per point (e.g. a quick look before the real run).
    #[arg(long)]
    pub trials: Option<u64>,
    /// Print the study file (a built-in one's TOML, to copy and edit) and exit.
    #[arg(long)]
    pub print: bool,
    #[command(flatten)]
    pub shard: crate::shard::ShardArgs,
    #[command(flatten)]
    pub cluster: crate::shard::ClusterArgs,
    #[command(flatten)]
    pub render: crate::common::RenderArg,
    #[command(flatten)]
    pub render_cache: crate::shard::RenderCacheArg,
}

#[derive(Debug, clap::Subcommand)]
pub enum StudyCommand {
    /// Merge a study's (or `waggle trials`') shard directories into DIR: the same study.json,
    /// trials.json, report.md and figures as one process would write, and cost.json summed.
    Merge(crate::shard::MergeArgs),
}

/// The help of the study argument, naming every built-in study, so no help text keeps its own
/// list.
fn study_arg_help() -> String {
    let names: Vec<&str> = run_format::study::BUILT_IN
        .iter()
        .map(|(name, _)| *name)
        .collect();
    format!(
        "A study file (TOML) or a built-in study: {} (`--print` shows one to copy and edit)",
        names.join(", ")
    )
}
