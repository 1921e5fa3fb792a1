//! `waggle decode --events FILE | --rgb PATH`: a camera's recording through one observer's
//! receiver ([`crate::harness::decode`]).

use anyhow::{Result, bail};
use proto::scene::{Formation, MAX_OBSERVERS, Placement, observer_name};

use crate::harness::decode::{DecodeInput, DecodeOptions, decode};
use commands::common::CameraPlaceArgs;
use commands::decode::DecodeArgs;
use commands::decode::EventFormat;

/// Where the camera was: its viewpoint, or its observer's place in the built-in formation.
pub(crate) fn placement(args: &CameraPlaceArgs) -> Result<Placement> {
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
        placement: placement(&args.camera)?,
        rectification: args.rectify,
        frame_check: args.check.frame_check,
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
