//! ROS 2 bags from Waggle recordings (`waggle export ros2`).
//!
//! A bag here is what rosbag2 of ROS 2 **Jazzy Jalisco** (the LTS release current in 2026) writes
//! with its MCAP storage plugin: a directory holding `<name>_0.mcap` (profile `ros2`, messages in
//! `cdr`, schemas in `ros2msg` with every dependency concatenated as rosbag2 does, channel
//! metadata `offered_qos_profiles` and `topic_type_hash`, a `rosbag2` metadata record) and a
//! `metadata.yaml` (rosbag2 metadata version 9) laid out byte for byte as rosbag2's yaml-cpp
//! emitter lays it out.
//!
//! - [`cdr`]: the CDR encoder (XCDR1, little-endian, 4-byte encapsulation header `00 01 00 00`)
//!   and a bounds-checked reader;
//! - [`definitions`]: the `.msg` definitions the bag carries (our own field-only definitions of
//!   the standard Jazzy types and Waggle's own `waggle_msgs`, kept in `libs/ros2/msg/`), their
//!   `ros2msg` full text and RIHS01 type hashes;
//! - [`messages`], [`waggle_msgs`]: the message structs and their CDR encoding;
//! - [`bag`]: the bag writer ([`BagWriter`]) and `metadata.yaml`;
//! - [`geometry`]: camera intrinsics (`CameraInfo`) and the camera's optical frame from Waggle's
//!   camera model;
//! - [`convert`]: Waggle messages → ROS 2 messages, shared by the export and the live view;
//! - [`export`]: a recording (`session.mcap`) → a bag, deterministic (the same run gives the same
//!   bytes) and sorted by time;
//! - [`rmw_zenoh`] and [`live`]: the same messages published live as ROS 2 Jazzy's Zenoh
//!   middleware publishes them (`waggle run --ros2-domain N`), and a camera's topic received
//!   as its subscriptions receive (`waggle observe`);
//! - [`ingest`]: an `event_camera_msgs` bag read back into events (`waggle decode`), and one
//!   camera message at a time; [`camera`]: a live camera's messages cut into the receivers'
//!   packets (`waggle observe`, a camera process fed by a ROS 2 camera).
//!
//! Pure apart from the files it reads and writes and [`live`]'s Zenoh session; errors are
//! [`Ros2Error`].

pub mod bag;
pub mod camera;
pub mod cdr;
pub mod convert;
pub mod definitions;
pub mod error;
pub mod export;
pub mod geometry;
pub mod ingest;
pub mod live;
pub mod messages;
pub mod rmw_zenoh;
pub mod waggle_msgs;

pub use bag::{BagSummary, BagWriter, QosProfile, TopicSpec};
pub use cdr::{CdrEncode, CdrError, CdrReader, CdrWriter, RosMessage};
pub use convert::{Converted, RosConverter};
pub use convert::{ExportOptions, ImageFormat};
pub use error::Ros2Error;
pub use export::{ExportReport, Substitute, Substituted, export_run, export_run_with};

/// The ROS 2 release whose rosbag2 format the bags follow (`ros_distro` in `metadata.yaml`).
pub const ROS_DISTRO: &str = "jazzy";
