//! `sim-node`: the physics process of a Waggle session, plus tools that exercise the scene.
// `--help` texts name files such as `O<i>.png`, which rustdoc would read as HTML.
#![allow(rustdoc::invalid_html_tags)]

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use sim::render::CameraRenderer;
use sim::world::World;

mod events;
mod node_camera;
mod node_run;
mod ros2_source;

#[derive(Parser)]
#[command(
    name = "sim-node",
    version,
    about = "Waggle physics and camera process"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// The physics process of a distributed session: steps the world in lockstep with the
    /// performer and scheduler, publishing the clock, ground-truth state and contacts.
    Run(node_run::SimRunArgs),
    /// One observer's camera process: renders its view from `sim/state` and publishes RGB
    /// frames or event packets.
    Camera(Box<node_camera::CameraCli>),
    /// Write each observer's current view as DIR/O<i>.png, then time 200 full renders per camera.
    Snapshot {
        /// Number of observers (1..=8).
        #[arg(long, default_value_t = 3)]
        observers: usize,
        /// Output directory (created if missing).
        #[arg(long)]
        out: PathBuf,
        /// Renders per camera for the timing.
        #[arg(long, default_value_t = 200)]
        frames: usize,
    },
    /// Fly a short left–right motion, convert each observer's 100 Hz renders to events, and write
    /// DIR/summary.json (packets, events, ON, OFF per observer) and event-frame PNGs.
    Events {
        /// Number of observers (1..=8).
        #[arg(long, default_value_t = 3)]
        observers: usize,
        /// Simulated seconds.
        #[arg(long, default_value_t = 5.0)]
        seconds: f64,
        /// Output directory (created if missing).
        #[arg(long)]
        out: PathBuf,
        /// Black out this observer's input before conversion (e.g. O2); repeatable.
        #[arg(long)]
        black: Vec<String>,
    },
}

fn main() -> Result<()> {
    node_args::init_logging();
    match Cli::parse().command {
        Command::Run(args) => node_run::run(args),
        Command::Camera(args) => node_camera::run(*args),
        Command::Snapshot {
            observers,
            out,
            frames,
        } => snapshot(observers, &out, frames),
        Command::Events {
            observers,
            seconds,
            out,
            black,
        } => events::run(observers, seconds, &out, &black),
    }
}

fn snapshot(observers: usize, out: &std::path::Path, frames: usize) -> Result<()> {
    let mut world = World::new(observers).context("building the scene")?;
    let mut renderer = CameraRenderer::new(&world, sim::render::RenderPath::Full)
        .context("creating the offscreen renderer")?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    for i in 0..observers {
        let rgb = renderer.render(&mut world, i)?.to_vec();
        let path = out.join(format!("{}.png", proto::scene::observer_name(i)));
        image::save_buffer_with_format(
            &path,
            &rgb,
            u32::from(proto::scene::IMAGE_WIDTH_PX),
            u32::from(proto::scene::IMAGE_HEIGHT_PX),
            image::ExtendedColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .with_context(|| format!("writing {}", path.display()))?;
        println!("wrote {}", path.display());
    }
    let start = Instant::now();
    for _ in 0..frames {
        for i in 0..observers {
            renderer.render(&mut world, i)?;
        }
    }
    let ms = start.elapsed().as_secs_f64() * 1e3 / (frames * observers).max(1) as f64;
    println!("render_ms_per_frame={ms:.3}");
    Ok(())
}
