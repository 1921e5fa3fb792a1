//! `waggle viewpoints`: decode success against viewing angle and distance
//! ([`crate::harness::link::viewpoints`]).

use std::io::Write as _;

use anyhow::{Context, Result};

use crate::harness::link::viewpoints::{ViewpointOptions, markdown, measure};
use commands::viewpoints::ViewpointsArgs;

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
