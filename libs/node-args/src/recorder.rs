//! `recorder-node`'s arguments: what the compose file decides ([`RecorderArgs`]) and what the
//! launcher of the recorder's host adds ([`RecorderOutput`]: paths in its run directory, the
//! live view's address, the live ROS 2 view's domain and router).

use std::net::SocketAddr;
use std::path::PathBuf;

use proto::Modality;

use crate::{ArgList, SensorArgs};

/// The recorder of a session, as composed.
#[derive(Debug, Clone, PartialEq, clap::Args)]
pub struct RecorderArgs {
    /// Case name, stored in the recording's metadata.
    #[arg(long)]
    pub case_name: Option<String>,
    /// Observer sensor modality, stored in the metadata.
    #[arg(long, value_enum)]
    pub modality: Option<Modality>,
    /// Rate of the event-frame pictures in the `/view/<o>/events` channels, Hz (0: none).
    #[arg(long, default_value_t = 2.0)]
    pub event_view_hz: f64,
    /// A view image (`/view/<o>/rgb`) of every n-th RGB frame; the raw channel holds every
    /// update the camera published (lossless: replayable) whatever this is.
    #[arg(long, default_value_t = 25)]
    pub rgb_every: u64,
    /// A view image of every RGB frame (same as `--rgb-every 1`).
    #[arg(long)]
    pub all_rgb: bool,
    /// Uncompressed chunk size, KiB.
    #[arg(long, default_value_t = 4096)]
    pub chunk_kib: u64,
    /// Close the current chunk and flush the file at least this often, ms of wall time.
    #[arg(long, default_value_t = 1000)]
    pub flush_ms: u64,
    /// After `MissionEnd`, stop once nothing arrived for this long, ms.
    #[arg(long, default_value_t = 1000)]
    pub linger_ms: u64,
    /// Keep the event cameras' input (`camera/<o>/input`, published by cameras given
    /// `--publish-input`) instead of their packets; replay regenerates the packets with the
    /// sensor model below, stored in the metadata.
    #[arg(long)]
    pub events_from_input: bool,
    /// The event cameras' sensor model, stored in the metadata.
    #[command(flatten)]
    pub sensor: SensorArgs,
}

impl RecorderArgs {
    /// A recorder of case `case_name` with `modality` cameras, every other option at its default.
    pub fn new(case_name: &str, modality: Modality) -> Self {
        Self {
            case_name: Some(case_name.to_string()),
            modality: Some(modality),
            event_view_hz: 2.0,
            rgb_every: 25,
            all_rgb: false,
            chunk_kib: 4096,
            flush_ms: 1000,
            linger_ms: 1000,
            events_from_input: false,
            sensor: SensorArgs::default(),
        }
    }

    /// The arguments that reproduce these.
    pub fn to_args(&self) -> Vec<String> {
        ArgList::new()
            .opt("--case-name", self.case_name.as_ref())
            .opt("--modality", self.modality.map(|m| m.as_str()))
            .value("--event-view-hz", self.event_view_hz)
            .value("--rgb-every", self.rgb_every)
            .flag("--all-rgb", self.all_rgb)
            .value("--chunk-kib", self.chunk_kib)
            .value("--flush-ms", self.flush_ms)
            .value("--linger-ms", self.linger_ms)
            .flag("--events-from-input", self.events_from_input)
            .done()
            .into_iter()
            .chain(self.sensor.to_args())
            .collect()
    }
}

/// Where the recorder writes, decided by the launcher of its host.
#[derive(Debug, Clone, PartialEq, Eq, clap::Args)]
pub struct RecorderOutput {
    /// The MCAP file to write (its directory is created).
    #[arg(long)]
    pub out: PathBuf,
    /// Case TOML file, stored (its text) in the recording's metadata.
    #[arg(long)]
    pub case_file: Option<PathBuf>,
    /// Serve the view channels live over a Foxglove WebSocket on this loopback address
    /// (e.g. `127.0.0.1:8765`), while recording.
    #[arg(long, value_name = "ADDR:PORT")]
    pub live: Option<SocketAddr>,
    /// Also publish the session live as ROS 2 topics, as ROS 2 Jazzy's `rmw_zenoh` does, in
    /// this ROS domain (`ROS_DOMAIN_ID`): the topics `waggle export ros2` writes.
    #[arg(long, value_name = "N")]
    pub ros2_domain: Option<u32>,
    /// The ROS side's Zenoh router for --ros2-domain (default: tcp/localhost:7447, where
    /// `rmw_zenohd` listens).
    #[arg(long, value_name = "ENDPOINT", requires = "ros2_domain")]
    pub ros2_router: Option<String>,
}

impl RecorderOutput {
    /// The arguments that reproduce these.
    pub fn to_args(&self) -> Vec<String> {
        ArgList::new()
            .value("--out", self.out.display())
            .opt("--case-file", self.case_file.as_ref().map(|p| p.display()))
            .opt("--live", self.live)
            .opt("--ros2-domain", self.ros2_domain)
            .opt("--ros2-router", self.ros2_router.as_ref())
            .done()
    }
}
