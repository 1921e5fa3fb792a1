//! `waggle viewpoints`: decode success against viewing angle and distance
//! ([`crate::harness::viewpoints`]).

use std::io::Write as _;
use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use proto::{Receiver, Rectification};

use crate::harness::link::parse_bits6;
use crate::harness::viewpoints::{ViewpointOptions, markdown, measure};

#[derive(Debug, Args)]
pub struct ViewpointsArgs {
    /// Azimuths from the gesture plane's normal, degrees (comma-separated).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "0,10,20,30,40,50,60,70,80"
    )]
    azimuths: Vec<f64>,
    /// Elevation above the hover altitude, degrees (the camera is pitched to aim at the
    /// performer).
    #[arg(long, default_value_t = 0.0)]
    elevation: f64,
    /// Distances from the hover point, metres (comma-separated).
    #[arg(long, value_delimiter = ',', default_value = "1.3")]
    distances: Vec<f64>,
    /// Receivers to measure (comma-separated).
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "ideal,rgb,events"
    )]
    modality: Vec<Receiver>,
    /// Rectifications to measure (comma-separated).
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "pitched,frontal"
    )]
    rectify: Vec<Rectification>,
    /// Six-bit payloads to broadcast (repeatable).
    #[arg(long = "payload", value_parser = parse_bits6, default_values = ["011010"])]
    payloads: Vec<u8>,
    #[command(flatten)]
    render: super::RenderArg,
    /// Also write the JSON results here.
    #[arg(long)]
    json: Option<PathBuf>,
}

pub fn run(args: ViewpointsArgs) -> Result<()> {
    for &az in &args.azimuths {
        super::link::parse_viewpoint(&format!("{az},{},1.3", args.elevation))
            .map_err(anyhow::Error::msg)?;
    }
    for &d in &args.distances {
        super::link::parse_viewpoint(&format!("0,0,{d}")).map_err(anyhow::Error::msg)?;
    }
    let out = measure(
        &ViewpointOptions {
            azimuths_deg: args.azimuths,
            elevation_deg: args.elevation,
            distances_m: args.distances,
            receivers: args.modality,
            rectifications: args.rectify,
            payloads: args.payloads,
            render: args.render.path,
        },
        |done, total| {
            eprint!("\rviewpoints: flight {done}/{total}");
            let _ = std::io::stderr().flush();
        },
    )?;
    eprintln!();
    print!("{}", markdown(&out));
    println!("({:.0} s wall)", out.wall_seconds);
    if let Some(path) = args.json {
        std::fs::write(&path, serde_json::to_string_pretty(&out)?)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}
