//! `waggle decode --events FILE`: an event camera's recording through one observer's event
//! receiver ([`crate::harness::decode`]).

use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::Args;
use proto::Rectification;
use proto::scene::{Formation, MAX_OBSERVERS, Placement, observer_name};

use crate::harness::decode::{DecodeOptions, decode_events_file};
use crate::harness::link::parse_viewpoint;

#[derive(Debug, Args)]
pub struct DecodeArgs {
    /// An event recording: Prophesee EVT 3.0 (`.raw`), e.g. from `waggle link --events-raw`.
    #[arg(long, value_name = "FILE")]
    events: PathBuf,
    /// Where the camera was: AZIMUTH_DEG,ELEVATION_DEG,DISTANCE_M from the performer's hover
    /// point (as `waggle link --viewpoint`).
    #[arg(long, value_name = "AZ,EL,DIST", value_parser = parse_viewpoint, conflicts_with = "observer")]
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
    /// Silence appended after the last event, s (so a final rest is confirmed).
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
    let out = decode_events_file(&DecodeOptions {
        file: args.events.clone(),
        placement: placement(&args)?,
        rectification: args.rectify,
        tail_s: args.tail_s,
    })?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        println!(
            "{}: {} events in {} packets ({:.2} s)",
            out.file, out.events, out.packets, out.sim_seconds
        );
        println!(
            "tokens {} · frames {} · payloads [{}]",
            out.decoded.tokens.len(),
            out.decoded.frames.len(),
            out.decoded.payloads.join(", ")
        );
    }
    Ok(())
}
