//! `waggle inputs`: one trial's sensor inputs streamed out with its ground truth, in the plug-in
//! pipe's frames (`receiver_plugin::wire`), for the Python package (`waggle.read_inputs`) and
//! anyone training a receiver on labelled data.
//!
//! The stream: a `trial` frame (the condition, each observer as a plug-in sees it, the
//! broadcast's labelled timeline and offers), then every input in the order the receivers get
//! them (`events` or `rgb`, each with its observer and the performer's image position), then an
//! `end` frame with the ideal receiver's tokens and releases. The inputs are exactly those
//! trial `--trial` of `waggle trials` with the same arguments gives its receivers.

use std::io::Write;
use std::sync::mpsc::sync_channel;

use anyhow::{Context, Result, bail};
use perturb::seed::trial_seed;
use proto::TruthSymbol;
use proto::scene::observer_name;
use receiver_plugin::ObserverInfo;
use receiver_plugin::wire;
use serde_json::{Value, json};

use crate::harness::link::ObserverOut;
use crate::harness::trials::TrialsOptions;
use crate::harness::trials::observer::{Tapped, TappedInput};
use crate::harness::trials::tap::tap_trial;
use commands::inputs::InputsArgs;

/// Inputs in flight between the flight and the writer: enough to keep both busy, few enough
/// that RGB frames do not pile up.
const QUEUE: usize = 8;

fn options(args: &InputsArgs) -> Result<TrialsOptions> {
    let perturbation = super::trials::perturbation_with(
        &args.perturb,
        args.real_noise.as_deref(),
        args.real_noise_static,
    )?;
    let formation = super::trials::formation(args.observers, &args.viewpoints)?;
    let Some(trials) = args.trial.checked_add(1) else {
        bail!("--trial {} is too large", args.trial);
    };
    let opts = TrialsOptions {
        payloads: args.link.clone(),
        formation,
        modality: args.modality,
        trials,
        seed: args.seed,
        perturbation,
        jobs: 1,
        render: args.render.path,
        rectification: args.rectify,
        acquisition: args.acquisition,
        plugin: None,
        frame_check: proto::FrameCheck::None,
    };
    opts.check()?;
    Ok(opts)
}

fn symbol_name(symbol: TruthSymbol) -> String {
    match symbol.token() {
        Some(token) => wire::token_name(token),
        None => "ACQUISITION".to_owned(),
    }
}

/// The `trial` frame's header.
fn trial_header(opts: &TrialsOptions, trial: u64) -> Result<Value> {
    let seed = trial_seed(opts.seed, trial);
    let schedule = opts.trial_schedule(trial)?;
    let observers: Vec<ObserverInfo> = opts
        .formation
        .placements()
        .iter()
        .enumerate()
        .map(|(i, p)| {
            ObserverInfo::new(observer_name(i), opts.modality, p, opts.rectification, seed)
        })
        .collect();
    let timeline: Vec<Value> = schedule
        .timeline()
        .iter()
        .map(|span| {
            json!({
                "symbol": symbol_name(span.symbol),
                "start_ns": span.start_ns, "end_ns": span.end_ns,
                "offer": span.slot.map(|s| s.offer_index),
                "payload": span.slot.map(|s| s.payload),
                "position": span.slot.map(|s| s.position),
            })
        })
        .collect();
    let offers: Vec<Value> = schedule
        .offers()
        .iter()
        .map(|o| {
            json!({"payload": o.payload, "start_ns": o.start_ns,
                   "final_null_start_ns": o.final_null_start_ns})
        })
        .collect();
    Ok(json!({
        "op": "trial", "modality": opts.modality, "trial": trial, "seed": seed,
        "perturb": opts.perturbation.recorded(),
        "observers": observers, "timeline": timeline, "offers": offers,
    }))
}

/// An input's frame: the plug-in pipe's header, with its observer and the performer's place.
fn input_frame(t: &Tapped) -> Vec<u8> {
    let observer = observer_name(t.observer);
    let ego = t.ego.map(|e| e.world_from_home);
    let (mut header, bulk) = match &t.input {
        TappedInput::Events(p) => (wire::events_header(&observer, p, ego), wire::events_bulk(p)),
        TappedInput::Rgb(f) => (wire::rgb_header(&observer, f, ego), f.rgb.clone()),
    };
    header["performer_px"] = json!(t.performer_px);
    wire::encode(&header, &bulk)
}

/// The ideal receiver's decodes, stamps back in integer nanoseconds.
fn ideal_json(outs: &[ObserverOut]) -> Value {
    let ns = |t_s: f64| (t_s * 1e9).round() as u64;
    Value::Object(
        outs.iter()
            .enumerate()
            .map(|(i, o)| {
                let tokens: Vec<Value> = o
                    .tokens
                    .iter()
                    .map(|t| json!([t.token, ns(t.t_s)]))
                    .collect();
                let frames: Vec<Value> = o
                    .frames
                    .iter()
                    .map(|f| json!([f.payload, ns(f.final_null_s)]))
                    .collect();
                (
                    observer_name(i),
                    json!({"tokens": tokens, "frames": frames}),
                )
            })
            .collect(),
    )
}

fn is_broken_pipe(e: &std::io::Error) -> bool {
    e.kind() == std::io::ErrorKind::BrokenPipe
}

pub fn run(args: InputsArgs) -> Result<()> {
    let opts = options(&args)?;
    let mut out: Box<dyn Write> = if args.out.as_os_str() == "-" {
        Box::new(std::io::BufWriter::new(std::io::stdout().lock()))
    } else {
        Box::new(std::io::BufWriter::new(
            std::fs::File::create(&args.out)
                .with_context(|| format!("creating {}", args.out.display()))?,
        ))
    };
    let header = trial_header(&opts, args.trial)?;
    match out.write_all(&wire::encode(&header, &[])) {
        Err(e) if is_broken_pipe(&e) => return Ok(()),
        other => other.context("writing the stream")?,
    }
    let (sender, inputs) = sync_channel::<Tapped>(QUEUE);
    let flown = std::thread::scope(|scope| -> Result<_> {
        let flight = scope.spawn(|| {
            let sender = sender;
            tap_trial(&opts, args.trial, &sender)
        });
        let mut written = Ok(());
        for tapped in inputs.iter() {
            written = out.write_all(&input_frame(&tapped));
            if written.is_err() {
                break;
            }
        }
        // Dropping the receiver stops a flight whose reader went away.
        drop(inputs);
        let flown = flight
            .join()
            .map_err(|_| anyhow::anyhow!("the flight's thread panicked"))?;
        match written {
            Err(e) if is_broken_pipe(&e) => Ok(None),
            other => {
                other.context("writing the stream")?;
                flown
            }
        }
    })?;
    let Some(flown) = flown else {
        return Ok(());
    };
    let ideal = flown
        .ideal
        .get(&opts.modality)
        .map_or(Value::Null, |o| ideal_json(o));
    let end = json!({"op": "end", "sim_ns": flown.sim_ns, "ideal": ideal});
    match out
        .write_all(&wire::encode(&end, &[]))
        .and_then(|()| out.flush())
    {
        Err(e) if is_broken_pipe(&e) => Ok(()),
        other => other.context("writing the stream"),
    }
}
