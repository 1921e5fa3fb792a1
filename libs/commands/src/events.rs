//! `waggle events`: synthetic event camera tools.

use clap::{Args, Subcommand};
use event_camera::DEFAULT_THRESHOLD;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct EventsArgs {
    #[command(subcommand)]
    pub command: EventsCommand,
}

#[derive(Debug, Subcommand)]
pub enum EventsCommand {
    /// Convert same-size PNG frames (sorted by name) into synthetic events `t_ns,x,y,p`.
    Convert(ConvertArgs),
}

#[derive(Debug, Args)]
pub struct ConvertArgs {
    /// Frame rate of the input frames, Hz.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub fps: u32,
    /// Directory of PNG frames.
    #[arg(long = "in", value_name = "FRAMES_DIR")]
    pub input: PathBuf,
    /// Output CSV file.
    #[arg(long, value_name = "EVENTS_CSV")]
    pub out: PathBuf,
    /// Contrast threshold C in log intensity.
    #[arg(long, default_value_t = DEFAULT_THRESHOLD)]
    pub threshold: f64,
}
