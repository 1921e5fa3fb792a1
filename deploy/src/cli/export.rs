//! `waggle export ros2 RUN_DIR --out BAG_DIR`: a run's recording as a ROS 2 bag (rosbag2 of ROS 2
//! Jazzy, MCAP storage), through [`ros2_bag::export_run`].

use std::io::Write;
use std::time::Instant;

use anyhow::{Context, Result};
use ros2_bag::{ExportOptions, ImageFormat, export_run_with};

use crate::eval::regenerate::{ExportedEvents, Regenerator};
use commands::export::{ExportArgs, ExportFormat};

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
