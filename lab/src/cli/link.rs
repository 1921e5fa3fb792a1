//! `waggle link`: the in-process link harness ([`crate::harness::link`]).
//!
//! One process steps physics, flies the broadcast, renders each observer's camera at its
//! modality's rate and feeds each observer's receiver only its own sensor data. It is the fast
//! bench on which receivers are developed and tested without Zenoh.
//!
//! With `--sensor-preset`/`--perturb events.*` the event sensors are not the paper's ideal
//! ones: see `fly_link_with_sensors`.

use std::time::Instant;

use anyhow::{Context, Result, bail};
use event_camera::{CameraConfig, EventCamera};
use perception::{Perception, SensorInput};
use perturb::Perturbation;
use perturb::seed::{Stream, stream_seed};
use proto::scene::{IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX, observer_name};
use proto::{Modality, Receiver};
use sim::sensor::EVENT_RENDER_PERIOD_NS;

use crate::harness::flight::rendered::{FlightSpec, fly_rendered};
use crate::harness::link::{LinkOptions, LinkOut, fly_link, observer_out, print_table};
pub use commands::common::{parse_bits6, parse_viewpoint};
use commands::link::LinkArgs;
use node_args::SensorArgs;
use run_format::run_dir::SensorRecord;

/// The sensor model of `args`, checked: `None` for the paper's ideal sensors.
fn sensor(args: &LinkArgs) -> Result<Option<(Perturbation, SensorRecord)>> {
    let spec = SensorArgs {
        preset: args.perturb.sensor_preset.clone(),
        perturb: args.perturb.perturb.clone(),
        seed: args.seed,
    };
    let Some(record) = run_eval::sensor::record(&spec)? else {
        return Ok(None);
    };
    if args.modality != Receiver::Events {
        bail!(
            "--sensor-preset/--perturb set the event sensors' model; --modality is {} (use \
             --modality events)",
            format!("{:?}", args.modality).to_lowercase()
        );
    }
    let p = spec.perturbation()?;
    if !p.is_none() && !args.black.is_empty() {
        bail!("--black cannot be combined with --sensor-preset/--perturb in `waggle link` yet");
    }
    Ok(Some((p, record)))
}

pub fn run(args: LinkArgs) -> Result<()> {
    let sensor = sensor(&args)?;
    let opts = LinkOptions {
        observers: args.observers,
        modality: args.modality,
        payloads: args.payloads,
        no_acquisition: args.no_acquisition,
        hover_s: args.hover_s,
        black: args.black,
        render: args.render.path,
        viewpoints: args.viewpoints,
        rectification: args.rectify,
        events_raw: args.events_raw,
        frame_check: args.check.frame_check,
    };
    if opts.events_raw.is_some() && opts.modality != Receiver::Events {
        bail!("--events-raw writes event cameras' events: use --modality events");
    }
    let out = match &sensor {
        // Terms at their defaults are the ideal sensor: the live link, unchanged.
        Some((p, record)) if !p.is_none() => fly_link_with_sensors(&opts, p, record.seed)?,
        _ => fly_link(&opts)?,
    };
    let record = sensor.map(|(_, r)| r);
    if args.json {
        let text = match &record {
            None => serde_json::to_string_pretty(&out)?,
            Some(r) => {
                let mut v = serde_json::to_value(&out)?;
                v["sensor"] = serde_json::to_value(r)?;
                serde_json::to_string_pretty(&v)?
            }
        };
        println!("{text}");
    } else {
        print_table(&out);
        if let Some(r) = &record {
            let terms: Vec<String> = r.perturb.iter().map(|(k, v)| format!("{k}={v}")).collect();
            println!(
                "event sensors: preset {} · {} · seed {}",
                r.preset.as_deref().unwrap_or("none"),
                terms.join(" "),
                r.seed
            );
        }
    }
    Ok(())
}

/// `waggle link` with event sensors that are not the paper's ideal ones. The broadcast is flown and
/// rendered once ([`fly_rendered`], the render cache `waggle trials` replays; an unperturbed replay
/// decodes exactly as the live link, `docs/decisions/seeded-trials-and-studies.md`) and each
/// observer's renders go through its own sensor — `perturbation`'s model seeded with
/// `stream_seed(seed, EventSensor, i)`, the sensor `waggle mission --seed` and `waggle run`'s
/// camera processes build — into its receiver.
///
/// It belongs beside [`fly_link`] in `harness::link` (as an option of [`LinkOptions`]); it is
/// here because that module was outside this change's scope.
fn fly_link_with_sensors(opts: &LinkOptions, p: &Perturbation, seed: u64) -> Result<LinkOut> {
    let formation = opts.formation()?;
    if !(opts.hover_s.is_finite() && opts.hover_s >= 0.0) {
        bail!("--hover-s {} must be a non-negative number", opts.hover_s);
    }
    let started = Instant::now();
    // Events modality only here (checked by `sensor`), so the sweep follows as in `fly_link`.
    let (schedule, end_ns) = opts.schedule()?;
    let flight = fly_rendered(FlightSpec {
        formation,
        schedule,
        end_ns,
        render_period_ns: EVENT_RENDER_PERIOD_NS,
        render: opts.render,
        rectification: opts.rectification,
        gusts: None,
        air: None,
    })?;
    let names: Vec<String> = (0..flight.spec.formation.len())
        .map(observer_name)
        .collect();
    let mut outs = Vec::new();
    for (i, placement) in flight.spec.formation.placements().iter().enumerate() {
        let mut perception =
            Perception::for_camera(Modality::Events, placement.camera(), opts.rectification)?;
        perception.set_frame_check(opts.frame_check);
        let config = CameraConfig::paper(IMAGE_WIDTH_PX, IMAGE_HEIGHT_PX)
            .with_model(p.event_sensor(stream_seed(seed, Stream::EventSensor, i)));
        let mut camera = EventCamera::new(config).context("event camera")?;
        let (mut tokens, mut frames) = (Vec::new(), Vec::new());
        let mut events = Vec::new();
        flight.tracks[i].replay(|t, rgb, change, ego| {
            perception.set_ego_rotation(ego);
            for packet in camera.push_frame_change(t, rgb, change)? {
                if opts.events_raw.is_some() {
                    crate::harness::flight::raw::packet_events(&packet, &mut events);
                }
                let step = perception.push(SensorInput::Events(&packet))?;
                tokens.extend(step.tokens);
                frames.extend(step.frames);
            }
            Ok(true)
        })?;
        outs.push(observer_out(&tokens, &frames));
        if let Some(dir) = &opts.events_raw {
            crate::harness::link::write_raws(dir, &names[i..=i], std::iter::once(&events[..]))?;
        }
    }
    let ideal = flight
        .ideal
        .get(&Modality::Events)
        .cloned()
        .unwrap_or_default();
    Ok(LinkOut {
        modality: "events".into(),
        observers: names.iter().cloned().zip(outs).collect(),
        sim_seconds: flight.sim_ns as f64 * 1e-9,
        wall_seconds: started.elapsed().as_secs_f64(),
        performer_max_tracking_error_m: flight.performer_max_tracking_error_m,
        ideal: Some(names.into_iter().zip(ideal).collect()),
        contact_steps: flight.contact_steps,
    })
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        link: super::LinkArgs,
    }

    fn sensor(
        args: &[&str],
    ) -> anyhow::Result<Option<(perturb::Perturbation, super::SensorRecord)>> {
        let cli = Cli::try_parse_from(std::iter::once("waggle-link").chain(args.iter().copied()))?;
        super::sensor(&cli.link)
    }

    #[test]
    fn an_unknown_sensor_preset_is_refused_naming_it_and_the_known_ones() {
        let e = format!(
            "{:#}",
            sensor(&["--modality", "events", "--sensor-preset", "v2e-loud"]).unwrap_err()
        );
        assert!(e.contains("v2e-loud") && e.contains("v2e-default"), "{e}");
        let e = format!(
            "{:#}",
            sensor(&["--modality", "events", "--perturb", "rgb.exposure_scale=2"]).unwrap_err()
        );
        assert!(e.contains("rgb.exposure_scale"), "{e}");
        for modality in ["ideal", "rgb"] {
            let e = format!(
                "{:#}",
                sensor(&["--modality", modality, "--sensor-preset", "v2e-clean"]).unwrap_err()
            );
            assert!(e.contains(modality), "{e}");
        }
        let e = format!(
            "{:#}",
            sensor(&[
                "--modality",
                "events",
                "--sensor-preset",
                "v2e-clean",
                "--black",
                "O2"
            ])
            .unwrap_err()
        );
        assert!(e.contains("--black"), "{e}");
    }

    #[test]
    fn the_sensor_model_is_recorded_and_none_without_a_preset_or_term() {
        assert!(sensor(&["--modality", "events"]).unwrap().is_none());
        let (p, record) = sensor(&[
            "--modality",
            "events",
            "--sensor-preset",
            "v2e-default",
            "--seed",
            "5",
        ])
        .unwrap()
        .unwrap();
        assert_eq!(record.preset.as_deref(), Some("v2e-default"));
        assert_eq!(record.seed, 5);
        assert_eq!(record.perturb, p.recorded());
        // A term at its default is the ideal sensor: the live link runs.
        let (p, _) = sensor(&["--modality", "events", "--perturb", "events.leak_hz=0"])
            .unwrap()
            .unwrap();
        assert!(p.is_none());
    }
}
