//! `waggle export`: a run's recording in other tools' formats (a ROS 2 bag).

use clap::{Args, Subcommand};
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct ExportArgs {
    #[command(subcommand)]
    pub format: ExportFormat,
}

#[derive(Debug, Subcommand)]
pub enum ExportFormat {
    /// A ROS 2 bag as rosbag2 of ROS 2 Jazzy writes it (MCAP storage, CDR messages,
    /// metadata.yaml): images, event packets (EVT 3.0), camera info, /tf and Waggle's own
    /// messages (waggle_msgs: tokens, frames, decisions, faults).
    Ros2(Ros2Args),
}

#[derive(Debug, Args)]
pub struct Ros2Args {
    /// A run directory written by `waggle run` (its session.mcap), or a recording file.
    pub run: PathBuf,
    /// The bag directory to create (it must not exist, or be empty).
    #[arg(long, value_name = "BAG_DIR")]
    pub out: PathBuf,
    /// RGB frames as raw `sensor_msgs/msg/Image` (rgb8) instead of lossless PNG
    /// `sensor_msgs/msg/CompressedImage`.
    #[arg(long)]
    pub raw_images: bool,
}
