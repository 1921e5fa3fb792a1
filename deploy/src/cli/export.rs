//! `waggle export ros2 RUN_DIR --out BAG_DIR`: a run's recording as a ROS 2 bag (rosbag2 of ROS 2
//! Jazzy, MCAP storage), through [`ros2_bag::export_run`].

use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::{Args, Subcommand};
use ros2_bag::{ExportOptions, ImageFormat, export_run_with};

use crate::eval::regenerate::{ExportedEvents, Regenerator};

#[derive(Debug, Args)]
pub struct ExportArgs {
    #[command(subcommand)]
    format: ExportFormat,
}

#[derive(Debug, Subcommand)]
enum ExportFormat {
    /// A ROS 2 bag as rosbag2 of ROS 2 Jazzy writes it (MCAP storage, CDR messages,
    /// metadata.yaml): images, event packets (EVT 3.0), camera info, /tf and Waggle's own
    /// messages (waggle_msgs: tokens, frames, decisions, faults).
    Ros2(Ros2Args),
}

#[derive(Debug, Args)]
struct Ros2Args {
    /// A run directory written by `waggle run` (its session.mcap), or a recording file.
    run: PathBuf,
    /// The bag directory to create (it must not exist, or be empty).
    #[arg(long, value_name = "BAG_DIR")]
    out: PathBuf,
    /// RGB frames as raw `sensor_msgs/msg/Image` (rgb8) instead of lossless PNG
    /// `sensor_msgs/msg/CompressedImage`.
    #[arg(long)]
    raw_images: bool,
}

pub fn run(args: ExportArgs) -> Result<()> {
    let ExportFormat::Ros2(args) = args.format;
    let started = Instant::now();
    let options = ExportOptions {
        images: if args.raw_images {
            ImageFormat::Raw
        } else {
            ImageFormat::Png
        },
    };
    // A recording of the event sensors' input: the packets are regenerated as it is read.
    let info = recording::leading_metadata(
        &run_eval::recording::resolve(&args.run),
        recording::SESSION_METADATA,
    )
    .with_context(|| format!("reading {}", args.run.display()))?
    .map(|m| recording::SessionInfo::from_metadata(&m))
    .unwrap_or_default();
    let mut regenerated = Regenerator::of(&info)?.map(ExportedEvents);
    let substitute = regenerated
        .as_mut()
        .map(|r| r as &mut dyn ros2_bag::Substitute);
    let report =
        export_run_with(&args.run, &args.out, &options, substitute).with_context(|| {
            format!(
                "exporting {} as a ROS 2 bag into {}",
                args.run.display(),
                args.out.display()
            )
        })?;
    let bag = &report.bag;
    // Written, not printed: a closed pipe (`| head`) is an error to report, not a panic.
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{}: {} messages on {} topics, {:.2} s of sim time, {} ({:.1} MB) in {:.1} s",
        bag.dir.display(),
        bag.message_count,
        bag.topics.len(),
        bag.duration_ns as f64 * 1e-9,
        bag.file_name,
        bag.file_bytes as f64 / 1e6,
        started.elapsed().as_secs_f64()
    )?;
    for t in &bag.topics {
        writeln!(
            out,
            "  {:<40} {:>7}  {}",
            t.name, t.message_count, t.type_name
        )?;
    }
    writeln!(
        out,
        "  {} events, {} images; not exported: {}",
        report.events,
        report.images,
        report
            .not_exported
            .iter()
            .map(|(topic, n)| format!("{topic} {n}"))
            .collect::<Vec<_>>()
            .join(", ")
    )?;
    Ok(())
}
