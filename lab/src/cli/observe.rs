//! `waggle observe --topic TOPIC`: a live camera through one observer's receiver
//! ([`crate::harness::decode::live`]).

use anyhow::{Context, Result};
use proto::ObserverId;
use ros2_bag::live::LiveOptions;

use crate::harness::decode::live::{ObserveOptions, observe};
use commands::observe::ObserveArgs;

pub fn run(args: ObserveArgs) -> Result<()> {
    let id = ObserverId::new(args.id.clone()).with_context(|| format!("--id {}", args.id))?;
    let out = observe(&ObserveOptions {
        live: LiveOptions {
            domain: args.ros2_domain,
            router: args.ros2_router.clone(),
            observers: args.camera.observers,
            session: format!("observe {}", args.topic),
        },
        topic: args.topic.clone(),
        kind: args.kind,
        id,
        placement: super::decode::placement(&args.camera)?,
        rectification: args.rectify,
        frame_check: args.check.frame_check,
        calibration: args.calibration.clone(),
        tail_s: args.tail_s,
        idle_s: args.idle_s,
    })?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&out)?);
        return Ok(());
    }
    let what = match (out.events, out.images) {
        (Some(e), _) => format!("{e} events"),
        (_, Some(i)) => format!("{i} images"),
        _ => String::new(),
    };
    println!(
        "{} ({}, {}×{}{}): {} messages ({} refused), {what}, {} packets to the receiver \
         ({:.2} s); ended: {}",
        out.topic,
        out.message_type,
        out.width_px,
        out.height_px,
        if out.remapped { ", remapped" } else { "" },
        out.messages,
        out.refused,
        out.packets,
        out.sim_seconds,
        out.ended
    );
    for reason in &out.refusals {
        println!("refused: {reason}");
    }
    println!(
        "payloads: {}",
        if out.decoded.payloads.is_empty() {
            "none".to_string()
        } else {
            out.decoded.payloads.join(", ")
        }
    );
    for (topic, n) in &out.published {
        println!("published {n} on {topic}");
    }
    Ok(())
}
