//! `waggle viewpoints`: decode success against viewing angle and distance.

use crate::common::parse_bits6;
use clap::Args;
use proto::{Receiver, Rectification};
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct ViewpointsArgs {
    /// Azimuths from the gesture plane's normal, degrees (comma-separated).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "0,10,20,30,40,50,60,70,80"
    )]
    pub azimuths: Vec<f64>,
    /// Elevation above the hover altitude, degrees (the camera is pitched to aim at the
    /// performer).
    #[arg(long, default_value_t = 0.0)]
    pub elevation: f64,
    /// Distances from the hover point, metres (comma-separated).
    #[arg(long, value_delimiter = ',', default_value = "1.3")]
    pub distances: Vec<f64>,
    /// Receivers to measure (comma-separated).
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "ideal,rgb,events"
    )]
    pub modality: Vec<Receiver>,
    /// Rectifications to measure (comma-separated).
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "pitched,frontal"
    )]
    pub rectify: Vec<Rectification>,
    /// Six-bit payloads to broadcast (repeatable).
    #[arg(long = "payload", value_parser = parse_bits6, default_values = ["011010"])]
    pub payloads: Vec<u8>,
    #[command(flatten)]
    pub render: crate::common::RenderArg,
    /// Also write the JSON results here.
    #[arg(long)]
    pub json: Option<PathBuf>,
}
