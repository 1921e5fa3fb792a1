//! `waggle mission`: a whole case in one process ([`crate::harness::mission`]).

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;

use crate::case::{Case, Receiver};
use crate::eval::summary::print_summary;
use crate::harness::mission::fly_case;
use crate::run_dir::SUMMARY_FILE;

#[derive(Debug, Args)]
pub struct MissionArgs {
    /// Built-in case name (one-observer, two-observers, nominal-3, black-o2, no-broadcast,
    /// only-a, dropout-o2) or a path to a case TOML file.
    case: String,
    /// Observer sensor modality (`ideal` is the ground-truth baseline).
    #[arg(long, value_enum, default_value_t = Receiver::Events)]
    modality: Receiver,
    #[command(flatten)]
    render: super::RenderArg,
    #[command(flatten)]
    flights: super::FlightsArg,
    /// Write DIR/summary.json here.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
}

pub fn run(args: MissionArgs) -> Result<()> {
    let case = args.flights.apply(Case::load(&args.case)?);
    if !case.modalities.contains(&args.modality) && args.modality != Receiver::Ideal {
        bail!(
            "case {} does not apply to the {:?} modality (it lists {:?})",
            case.name,
            args.modality,
            case.modalities
        );
    }
    let summary = fly_case(&case, args.modality, args.render.path)?;
    if let Some(dir) = &args.out {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let path = dir.join(SUMMARY_FILE);
        std::fs::write(&path, serde_json::to_string_pretty(&summary)?)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        print_summary(&summary);
    }
    if !summary.pass {
        bail!(
            "case {} did not meet its expected outcome: {}",
            summary.case,
            summary.reasons.join("; ")
        );
    }
    Ok(())
}
