//! `waggle observe`: one observer's receiver on a live camera, a ROS 2 topic on `rmw_zenoh`.

use crate::common::{CameraPlaceArgs, FrameCheckArg};
use clap::{Args, ValueEnum};
use proto::Rectification;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct ObserveArgs {
    /// The camera's ROS 2 topic, e.g. /event_camera/events (Prophesee's `metavision_driver`)
    /// or /camera/image_raw.
    #[arg(long)]
    pub topic: String,
    /// What the topic carries.
    #[arg(long, value_enum, default_value_t = LiveKind::default())]
    pub kind: LiveKind,
    /// ROS domain id (`ROS_DOMAIN_ID`).
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub ros2_domain: u32,
    /// The ROS side's Zenoh router (where `ros2 run rmw_zenoh_cpp rmw_zenohd` listens).
    #[arg(long, value_name = "ENDPOINT", default_value = "tcp/localhost:7447")]
    pub ros2_router: String,
    /// The observer this receiver is: it publishes /ID/tokens and /ID/frames
    /// (`waggle_msgs/msg/Token`, `Frame`).
    #[arg(long, default_value = "O1")]
    pub id: String,
    /// The camera's calibration: ROS `camera_info` YAML or OpenCV calibration YAML. The input
    /// is remapped into the receivers' reference camera (640×480, 45° vertical field); without
    /// it, a camera of another size is taken to have the reference's field of view.
    #[arg(long, value_name = "YAML")]
    pub calibration: Option<PathBuf>,
    #[command(flatten)]
    pub camera: CameraPlaceArgs,
    /// Viewpoint rectification of the receiver's trajectory before template matching.
    #[arg(long, value_enum, default_value_t = Rectification::default())]
    pub rectify: Rectification,
    #[command(flatten)]
    pub check: FrameCheckArg,
    /// Silence (events) or the last image held still (RGB) given to the receiver once the
    /// camera has gone, s (so a final rest is confirmed).
    #[arg(long, default_value_t = 2.0)]
    pub tail_s: f64,
    /// Also end after this many seconds with no message (0: only when the topic's publishers
    /// have left the ROS graph, or on Ctrl-C).
    #[arg(long, value_name = "S", default_value_t = 0.0)]
    pub idle_s: f64,
    /// Print machine-readable JSON instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// What a live camera topic carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ValueEnum)]
pub enum LiveKind {
    /// `event_camera_msgs/msg/EventPacket`, `encoding: "evt3"` (Prophesee's driver).
    #[default]
    Events,
    /// `sensor_msgs/msg/Image` (rgb8, bgr8, rgba8, bgra8, mono8).
    Image,
    /// `sensor_msgs/msg/CompressedImage` in PNG.
    CompressedImage,
}
