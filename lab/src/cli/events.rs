//! `waggle events convert`: PNG frames → synthetic events ([`crate::harness::convert`]).

use std::path::PathBuf;

use clap::{Args, Subcommand};
use event_camera::DEFAULT_THRESHOLD;

use crate::harness::convert::{ConvertOptions, convert};

#[derive(Args)]
pub struct EventsArgs {
    #[command(subcommand)]
    command: EventsCommand,
}

#[derive(Subcommand)]
enum EventsCommand {
    /// Convert same-size PNG frames (sorted by name) into synthetic events `t_ns,x,y,p`.
    Convert(ConvertArgs),
}

#[derive(Args)]
struct ConvertArgs {
    /// Frame rate of the input frames, Hz.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    fps: u32,
    /// Directory of PNG frames.
    #[arg(long = "in", value_name = "FRAMES_DIR")]
    input: PathBuf,
    /// Output CSV file.
    #[arg(long, value_name = "EVENTS_CSV")]
    out: PathBuf,
    /// Contrast threshold C in log intensity.
    #[arg(long, default_value_t = DEFAULT_THRESHOLD)]
    threshold: f64,
}

pub fn run(args: EventsArgs) -> anyhow::Result<()> {
    match args.command {
        EventsCommand::Convert(args) => {
            let summary = convert(&ConvertOptions {
                fps: args.fps,
                input: args.input,
                out: args.out,
                threshold: args.threshold,
            })?;
            println!("{summary}");
            Ok(())
        }
    }
}
