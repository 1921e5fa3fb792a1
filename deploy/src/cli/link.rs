//! `waggle link`: the in-process link harness ([`crate::harness::link`]).
//!
//! One process steps physics, flies the broadcast, renders each observer's camera at its
//! modality's rate and feeds each observer's receiver only its own sensor data. It is the fast
//! bench on which receivers are developed and tested without Zenoh.

use anyhow::Result;
use clap::Args;
use proto::scene::Placement;
use proto::{Receiver, Rectification};

use crate::harness::link::{LinkOptions, fly_link, print_table};
pub use crate::harness::link::{parse_bits6, parse_viewpoint};

#[derive(Debug, Args)]
pub struct LinkArgs {
    /// Number of observers (1..=8).
    #[arg(long, default_value_t = 3)]
    observers: usize,
    /// Observer sensor modality.
    #[arg(long, value_enum, default_value_t = Receiver::Ideal)]
    modality: Receiver,
    /// Six-bit payload to broadcast, e.g. 011010; repeat for back-to-back offers. Without any,
    /// the performer only hovers (a control: nothing may be decoded).
    #[arg(long = "payload", value_parser = parse_bits6)]
    payloads: Vec<u8>,
    /// Events modality: skip the acquisition sweep before the first offer (a control).
    #[arg(long)]
    no_acquisition: bool,
    /// Seconds to hover when no payload is given.
    #[arg(long, default_value_t = 30.0)]
    hover_s: f64,
    /// Black out this observer's camera from start-up (e.g. O2); repeatable.
    #[arg(long)]
    black: Vec<String>,
    /// Place an observer at AZIMUTH_DEG,ELEVATION_DEG,DISTANCE_M from the performer's hover
    /// point (azimuth from the gesture plane's normal, towards +x), aimed at it; repeat for up
    /// to 8 observers. Replaces the built-in formation of --observers.
    #[arg(long = "viewpoint", value_name = "AZ,EL,DIST", value_parser = parse_viewpoint)]
    viewpoints: Vec<Placement>,
    /// Viewpoint rectification of the receivers' trajectories before template matching.
    #[arg(long, value_enum, default_value_t = Rectification::default())]
    rectify: Rectification,
    #[command(flatten)]
    render: super::RenderArg,
    /// Print machine-readable JSON instead of the table.
    #[arg(long)]
    json: bool,
}

pub fn run(args: LinkArgs) -> Result<()> {
    let out = fly_link(&LinkOptions {
        observers: args.observers,
        modality: args.modality,
        payloads: args.payloads,
        no_acquisition: args.no_acquisition,
        hover_s: args.hover_s,
        black: args.black,
        render: args.render.path,
        viewpoints: args.viewpoints,
        rectification: args.rectify,
    })?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        print_table(&out);
    }
    Ok(())
}
