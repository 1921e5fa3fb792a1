//! `waggle decode --events FILE | --rgb PATH`: a camera's recording through one observer's
//! receiver ([`crate::harness::decode`]).

use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::Args;
use proto::Rectification;
use proto::scene::{Formation, MAX_OBSERVERS, Placement, observer_name};

use crate::harness::decode::source::EventFormat;
use crate::harness::decode::{DecodeInput, DecodeOptions, decode};
use crate::harness::link::parse_viewpoint;

#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("input").required(true).args(["events", "rgb"])))]
pub struct DecodeArgs {
    /// An event recording: Prophesee EVT 3.0 (`.raw`, e.g. from `waggle link --events-raw`),
    /// iniVation AEDAT4 (`.aedat4`) or a ROS 2 bag (MCAP storage: the directory or its `.mcap`
    /// file) of `event_camera_msgs/msg/EventPacket` in `evt3` encoding.
    #[arg(long, value_name = "FILE")]
    events: Option<PathBuf>,
    /// Or an RGB recording: a directory of PNG frames (name order, at --fps) or a ROS 2 bag's
    /// `sensor_msgs/msg/CompressedImage` (PNG) or `sensor_msgs/msg/Image` topic. A video is
    /// read after cutting it into frames, e.g. `ffmpeg -i in.mp4 frames/%06d.png`.
    #[arg(long, value_name = "PATH")]
    rgb: Option<PathBuf>,
    /// The event recording's format (by default told from the file).
    #[arg(long, value_enum, default_value_t = EventFormat::default())]
    format: EventFormat,
    /// A bag's topic (default: the only one of its kind, or O1's of a `waggle export ros2` bag).
    #[arg(long)]
    topic: Option<String>,
    /// Frame rate of a PNG directory, Hz.
    #[arg(long, default_value_t = 25)]
    fps: u32,
    /// The camera's calibration: ROS `camera_info` YAML or OpenCV calibration YAML (camera
    /// matrix, `plumb_bob`/`rational_polynomial` distortion). The recording is remapped into
    /// the receivers' reference camera (640×480, 45° vertical field). Without it, a recording
    /// of another size is taken to have the reference's field of view.
    #[arg(long, value_name = "YAML")]
    calibration: Option<PathBuf>,
    /// Where the camera was: AZIMUTH_DEG,ELEVATION_DEG,DISTANCE_M from the performer's hover
    /// point (as `waggle link --viewpoint`).
    #[arg(long, value_name = "AZ,EL,DIST", value_parser = parse_viewpoint, allow_hyphen_values = true, conflicts_with = "observer")]
    viewpoint: Option<Placement>,
    /// Or: the camera was observer OBSERVER (e.g. O2) of the built-in formation of --observers.
    #[arg(long)]
    observer: Option<String>,
    /// Size of the built-in formation --observer refers to.
    #[arg(long, default_value_t = 3)]
    observers: usize,
    /// Viewpoint rectification of the receiver's trajectory before template matching.
    #[arg(long, value_enum, default_value_t = Rectification::default())]
    rectify: Rectification,
    /// Silence (events) or the last image held still (RGB) appended after the recording, s
    /// (so a final rest is confirmed).
    #[arg(long, default_value_t = 2.0)]
    tail_s: f64,
    /// Print machine-readable JSON instead of the table.
    #[arg(long)]
    json: bool,
}

fn placement(args: &DecodeArgs) -> Result<Placement> {
    if let Some(p) = args.viewpoint {
        return Ok(p);
    }
    let Some(name) = &args.observer else {
        bail!("say where the camera was: --viewpoint AZ,EL,DIST or --observer Oi");
    };
    let formation = Formation::standard(args.observers).map_err(|_| {
        anyhow::anyhow!(
            "--observers {} is outside 1..={MAX_OBSERVERS}",
            args.observers
        )
    })?;
    let names: Vec<String> = (0..formation.len()).map(observer_name).collect();
    let Some(i) = names.iter().position(|n| n == name) else {
        bail!(
            "--observer {name}: no such observer (have {})",
            names.join(", ")
        );
    };
    Ok(formation.placements()[i])
}

pub fn run(args: DecodeArgs) -> Result<()> {
    let input = match (args.events.clone(), args.rgb.clone()) {
        (Some(file), _) => DecodeInput::Events {
            file,
            format: args.format,
            topic: args.topic.clone(),
        },
        (None, Some(path)) => {
            if args.format != EventFormat::Auto {
                bail!("--format names an event recording's format; --rgb reads PNG or a bag");
            }
            DecodeInput::Rgb {
                path,
                topic: args.topic.clone(),
                fps: args.fps,
            }
        }
        (None, None) => bail!("say what to decode: --events FILE or --rgb PATH"),
    };
    let out = decode(&DecodeOptions {
        input,
        placement: placement(&args)?,
        rectification: args.rectify,
        calibration: args.calibration.clone(),
        tail_s: args.tail_s,
    })?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        let what = match (out.events, out.images) {
            (Some(e), _) => format!("{e} events"),
            (_, Some(i)) => format!("{i} images"),
            _ => String::new(),
        };
        println!(
            "{} ({}, {}×{}{}): {what}, {} packets to the receiver ({:.2} s)",
            out.file,
            out.format,
            out.width_px,
            out.height_px,
            if out.remapped { ", remapped" } else { "" },
            out.packets,
            out.sim_seconds
        );
        if let Some(n) = out.events_outside.filter(|&n| n > 0) {
            println!("{n} events outside the reference camera's field, dropped");
        }
        println!(
            "tokens {} · frames {} · payloads [{}]",
            out.decoded.tokens.len(),
            out.decoded.frames.len(),
            out.decoded.payloads.join(", ")
        );
    }
    Ok(())
}
