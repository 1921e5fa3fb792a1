//! `waggle sensor-fit FILE`: a real camera's recording measured for the sensor model's terms
//! (`event_camera::fit`), printed and optionally written as a preset file.

use std::fmt::Write as _;

use anyhow::{Context, Result, bail};
use commands::sensor_fit::SensorFitArgs;
use event_camera::fit::{Background, SensorFit, fit};

use crate::harness::decode::source::read_events;

pub fn run(args: SensorFitArgs) -> Result<()> {
    let read = read_events(&args.file, args.format, args.topic.as_deref())?;
    let name = args.file.display().to_string();
    let Some(first) = read.events.first().map(|e| e.t_ns) else {
        bail!("{name}: the recording holds no events");
    };
    let (width, height) = read.sensor_size();
    let background = Background::from_window(first, args.static_window);
    let fitted =
        fit(&read.events, width, height, background).with_context(|| format!("fitting {name}"))?;
    let span_s = read.events.last().map_or(0, |e| e.t_ns - first) as f64 * 1e-9;
    if let Some(out) = &args.out {
        std::fs::write(out, preset_file(&name, &fitted))
            .with_context(|| format!("writing {}", out.display()))?;
    }
    if args.json {
        let json = to_json(&name, &read.format, read.events.len(), span_s, &fitted);
        println!("{}", serde_json::to_string_pretty(&json)?);
        return Ok(());
    }
    print!(
        "{}",
        report(&name, &read.format, read.events.len(), span_s, &fitted)
    );
    if let Some(out) = &args.out {
        println!(
            "preset written: {} (use it as --sensor-preset {})",
            out.display(),
            out.display()
        );
    }
    Ok(())
}

/// The measurement as JSON (serde_json's map keeps its keys sorted).
fn to_json(
    name: &str,
    format: &str,
    events: usize,
    span_s: f64,
    f: &SensorFit,
) -> serde_json::Value {
    let (background, window_ns) = match f.background {
        Background::Static { start_ns, end_ns } => ("static", Some([start_ns, end_ns])),
        Background::Isolated => ("isolated", None),
    };
    serde_json::json!({
        "file": name,
        "format": format,
        "width_px": f.width,
        "height_px": f.height,
        "events": events,
        "span_s": span_s,
        "background": background,
        "static_window_ns": window_ns,
        "background_events": f.background_events,
        "background_s": f.duration_s,
        "on_hz": f.on_hz,
        "off_hz": f.off_hz,
        "shot_noise_hz": f.shot_noise_hz,
        "leak_hz": f.leak_hz,
        "rate_spread_decades": f.rate_spread_decades,
        "on_spread_decades": f.on_spread_decades,
        "off_spread_decades": f.off_spread_decades,
        "on_crossings": f.crossings.on_crossings,
        "off_crossings": f.crossings.off_crossings,
        "on_events_per_crossing": f.crossings.on_events_per_crossing,
        "off_events_per_crossing": f.crossings.off_events_per_crossing,
        "hot_pixels": f.hot_pixels,
        "hot_pixel_hz": f.hot_pixel_hz,
        "refractory_floor_ns": f.refractory_floor_ns,
        "terms": f.terms().into_iter().map(|(k, v)| (k.to_owned(), v)).collect::<std::collections::BTreeMap<_, _>>(),
    })
}

fn report(name: &str, format: &str, events: usize, span_s: f64, f: &SensorFit) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "sensor-fit: {name} ({format}, {}×{}, {events} events over {span_s:.3} s)",
        f.width, f.height
    );
    let _ = match f.background {
        Background::Static { .. } => writeln!(
            s,
            "background: the static stretch, {} events over {:.3} s",
            f.background_events, f.duration_s
        ),
        Background::Isolated => writeln!(
            s,
            "background: {} events with no neighbour within 10 ms, over {:.3} s, corrected \
             for chance neighbours",
            f.background_events, f.duration_s
        ),
    };
    let _ = writeln!(s, "  on_hz per pixel       {:.6}", f.on_hz);
    let _ = writeln!(s, "  off_hz per pixel      {:.6}", f.off_hz);
    let _ = writeln!(
        s,
        "  shot_noise_hz         {:.6} (2 × off)",
        f.shot_noise_hz
    );
    let _ = writeln!(s, "  leak_hz               {:.6} (on − off)", f.leak_hz);
    let _ = writeln!(
        s,
        "  rate spread, decades  {:.3} (reported only: the model spreads the leak alone)",
        f.rate_spread_decades
    );
    let _ = writeln!(
        s,
        "    by polarity         ON {:.3}, OFF {:.3}",
        f.on_spread_decades, f.off_spread_decades
    );
    let _ = writeln!(
        s,
        "  hot pixels            {} (median {:.3} Hz){}",
        f.hot_pixels.len(),
        f.hot_pixel_hz,
        f.hot_pixels
            .iter()
            .take(8)
            .map(|(x, y)| format!(" ({x}, {y})"))
            .collect::<String>()
    );
    let _ = match f.refractory_floor_ns {
        Some(ns) => writeln!(
            s,
            "  refractory floor      {:.6} ms (0.1 % quantile of one pixel's intervals)",
            ns as f64 * 1e-6
        ),
        None => writeln!(
            s,
            "  refractory floor      not measured (too few intervals)"
        ),
    };
    let per_crossing = |mean: Option<f64>, count: u64| match mean {
        Some(m) => format!("{m:.3} over {count} crossings"),
        None => format!("not measured ({count} crossings)"),
    };
    let _ = writeln!(
        s,
        "  events per crossing   ON {}, OFF {} (a sharp edge of log contrast c: c / threshold)",
        per_crossing(f.crossings.on_events_per_crossing, f.crossings.on_crossings),
        per_crossing(
            f.crossings.off_events_per_crossing,
            f.crossings.off_crossings
        )
    );
    let _ = writeln!(s, "not measured: threshold mismatch, brightness dependence");
    s
}

fn preset_file(name: &str, f: &SensorFit) -> String {
    let mut s = format!(
        "# A Waggle sensor preset fitted by `waggle sensor-fit` from {name}\n\
         # ({}×{}; on {:.6} Hz, off {:.6} Hz per pixel; rate spread {:.3} decades).\n\
         # Use: --sensor-preset THIS_FILE (and --perturb KEY=VALUE over it).\n",
        f.width, f.height, f.on_hz, f.off_hz, f.rate_spread_decades
    );
    for (key, value) in f.terms() {
        let _ = writeln!(s, "{key} = {value}");
    }
    s
}
