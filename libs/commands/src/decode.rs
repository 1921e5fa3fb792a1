//! `waggle decode`: a camera's recording decoded by one observer's receiver, and the recording formats it reads.

use crate::common::{CameraPlaceArgs, FrameCheckArg};
use clap::{Args, ValueEnum};
use proto::Rectification;
use std::path::PathBuf;

#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("input").required(true).args(["events", "rgb"])))]
pub struct DecodeArgs {
    /// An event recording: Prophesee EVT 3.0 (`.raw`, e.g. from `waggle link --events-raw`),
    /// iniVation AEDAT4 (`.aedat4`) or a ROS 2 bag (MCAP storage: the directory or its `.mcap`
    /// file) of `event_camera_msgs/msg/EventPacket` in `evt3` encoding.
    #[arg(long, value_name = "FILE")]
    pub events: Option<PathBuf>,
    /// Or an RGB recording: a directory of PNG frames (name order, at --fps) or a ROS 2 bag's
    /// `sensor_msgs/msg/CompressedImage` (PNG) or `sensor_msgs/msg/Image` topic. A video is
    /// read after cutting it into frames, e.g. `ffmpeg -i in.mp4 frames/%06d.png`.
    #[arg(long, value_name = "PATH")]
    pub rgb: Option<PathBuf>,
    /// The event recording's format (by default told from the file).
    #[arg(long, value_enum, default_value_t = EventFormat::default())]
    pub format: EventFormat,
    /// A bag's topic (default: the only one of its kind, or O1's of a `waggle export ros2` bag).
    #[arg(long)]
    pub topic: Option<String>,
    /// Frame rate of a PNG directory, Hz.
    #[arg(long, default_value_t = 25)]
    pub fps: u32,
    /// The camera's calibration: ROS `camera_info` YAML or OpenCV calibration YAML (camera
    /// matrix, `plumb_bob`/`rational_polynomial` distortion). The recording is remapped into
    /// the receivers' reference camera (640×480, 45° vertical field). Without it, a recording
    /// of another size is taken to have the reference's field of view.
    #[arg(long, value_name = "YAML")]
    pub calibration: Option<PathBuf>,
    #[command(flatten)]
    pub camera: CameraPlaceArgs,
    /// Viewpoint rectification of the receiver's trajectory before template matching.
    #[arg(long, value_enum, default_value_t = Rectification::default())]
    pub rectify: Rectification,
    #[command(flatten)]
    pub check: FrameCheckArg,
    /// Silence (events) or the last image held still (RGB) appended after the recording, s
    /// (so a final rest is confirmed).
    #[arg(long, default_value_t = 2.0)]
    pub tail_s: f64,
    /// Print machine-readable JSON instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// An event recording's format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ValueEnum)]
pub enum EventFormat {
    /// Tell from the file: a directory or `\x89MCAP` is a bag, `#!AER-DAT4.0` AEDAT4, the
    /// `.dat` extension (or a `%` header with a `Version` line and no `evt`) DAT, another `%`
    /// header or the `.raw` extension EVT 3.0 or 2.0 (as its header says).
    #[default]
    Auto,
    /// Prophesee EVT 3.0 or EVT 2.0 (`.raw`), as its `% evt` header line says (3.0 without one).
    Raw,
    /// Prophesee DAT (`.dat`) of CD events.
    Dat,
    /// iniVation AEDAT 4.0 (`.aedat4`): its first event stream.
    Aedat4,
    /// A ROS 2 bag (MCAP storage; the directory or its `.mcap` file) of
    /// `event_camera_msgs/msg/EventPacket` in `evt3` encoding.
    Bag,
}
