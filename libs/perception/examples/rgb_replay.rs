//! Replays a directory of 25 Hz RGB PNG frames (sorted by name, frame k stamped (k + 1) · 40 ms)
//! through the RGB receiver and prints its tokens and released frames.
//!
//! `cargo run --release -p perception --example rgb_replay -- DIR [--trajectory OUT.csv]
//!  [--drop FIRST:COUNT]`
//!
//! `--ideal POINTS.csv` (lines `seq,stamp_ns,x_px,y_px`: the performer's projected ground
//! truth per frame) also runs the same segmenter and parser on those points and prints the
//! largest token-time offset of the RGB receiver from that ideal receiver.
//!
//! `--drop` withholds COUNT frames starting at index FIRST (a sequence gap); `--trajectory`
//! writes `seq,stamp_ns,x_px,y_px,reliable,features` per frame.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use perception::rgb::{RgbReceiver, RgbReceiverConfig, TrackEvent};
use proto::RgbFrame;
use proto::{Decoder, Sample, SegmenterConfig};

fn read_png(path: &Path) -> Result<(u32, u32, Vec<u8>)> {
    let file = std::fs::File::open(path).with_context(|| format!("opening {}", path.display()))?;
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
    let mut reader = decoder
        .read_info()
        .with_context(|| format!("reading {}", path.display()))?;
    let mut buf = vec![0; reader.output_buffer_size().context("png too large")?];
    let info = reader.next_frame(&mut buf)?;
    buf.truncate(info.buffer_size());
    let rgb = match info.color_type {
        png::ColorType::Rgb => buf,
        png::ColorType::Rgba => buf
            .chunks_exact(4)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect(),
        other => bail!("{}: unsupported colour type {other:?}", path.display()),
    };
    Ok((info.width, info.height, rgb))
}

/// The command line.
struct Options {
    dir: PathBuf,
    trajectory: Option<std::fs::File>,
    drop: std::ops::Range<usize>,
    ideal: Option<String>,
}

fn parse_args() -> Result<Options> {
    let mut args = std::env::args().skip(1);
    let dir = PathBuf::from(
        args.next()
            .context("usage: DIR [--trajectory OUT.csv] [--drop FIRST:COUNT]")?,
    );
    let mut trajectory: Option<std::fs::File> = None;
    let mut drop = 0..0;
    let mut ideal: Option<String> = None;
    while let Some(a) = args.next() {
        match a.as_str() {
            "--trajectory" => {
                let p = args.next().context("--trajectory needs a path")?;
                trajectory =
                    Some(std::fs::File::create(&p).with_context(|| format!("creating {p}"))?);
            }
            "--ideal" => {
                let p = args.next().context("--ideal needs a path")?;
                ideal = Some(std::fs::read_to_string(&p).with_context(|| format!("reading {p}"))?);
            }
            "--drop" => {
                let v = args.next().context("--drop needs FIRST:COUNT")?;
                let (f, c) = v.split_once(':').context("--drop needs FIRST:COUNT")?;
                let (f, c): (usize, usize) = (f.parse()?, c.parse()?);
                drop = f..f + c;
            }
            other => bail!("unknown argument {other}"),
        }
    }
    Ok(Options {
        dir,
        trajectory,
        drop,
        ideal,
    })
}

/// The paper's settings, with the developer knobs for parameter studies applied.
fn config_from_env() -> RgbReceiverConfig {
    let mut config = RgbReceiverConfig::paper();
    let knob = |name: &str| std::env::var(name).ok().and_then(|v| v.parse::<f64>().ok());
    if let Some(v) = knob("RGB_KLT_WINDOW_PX") {
        config.klt.window_px = v as usize;
    }
    if let Some(v) = knob("RGB_KLT_LEVELS") {
        config.klt.pyramid_levels = v as usize;
    }
    if let Some(v) = knob("RGB_FB_THRESHOLD_PX") {
        config.klt.fb_threshold_px = v as f32;
    }
    if let Some(v) = knob("RGB_REDETECT_PERIOD") {
        config.tracker.redetect_period_frames = v as u32;
    }
    if let Some(v) = knob("RGB_MAX_FEATURES") {
        config.tracker.max_features = v as usize;
    }
    config
}

fn main() -> Result<()> {
    let mut opts = parse_args()?;
    let mut paths: Vec<PathBuf> = std::fs::read_dir(&opts.dir)
        .with_context(|| format!("listing {}", opts.dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
        .collect();
    paths.sort();
    let mut rx = RgbReceiver::new(config_from_env())?;
    let started = std::time::Instant::now();
    let acquisitions = replay(&mut rx, &paths, &mut opts)?;
    let wall = started.elapsed().as_secs_f64();
    if let Some(text) = &opts.ideal {
        compare_with_ideal(&rx, text)?;
    }
    println!(
        "{} frames in {:.2} s ({:.3} ms/frame incl. PNG decode); {} acquisitions; released {:?}",
        paths.len(),
        wall,
        wall * 1e3 / paths.len().max(1) as f64,
        acquisitions,
        rx.frames()
            .iter()
            .map(|f| format!("{:06b}", f.payload))
            .collect::<Vec<_>>()
    );
    Ok(())
}

/// Feeds every frame not dropped to the receiver, printing as it goes; returns the number of
/// acquisitions.
fn replay(rx: &mut RgbReceiver, paths: &[PathBuf], opts: &mut Options) -> Result<usize> {
    let mut acquisitions = 0;
    for (k, path) in paths.iter().enumerate() {
        if opts.drop.contains(&k) {
            continue;
        }
        let (w, h, rgb) = read_png(path)?;
        let frame = RgbFrame {
            seq: k as u64,
            stamp_ns: (k as u64 + 1) * 40_000_000,
            width: u16::try_from(w)?,
            height: u16::try_from(h)?,
            valid: true,
            continuous: true,
            rgb,
        };
        let out = rx.push_frame(&frame);
        if let Some(t) = out.track {
            if t.event == TrackEvent::Acquired {
                acquisitions += 1;
            }
            if let TrackEvent::Lost(why) = t.event {
                println!("{:8.2} s lost: {why:?}", frame.stamp_ns as f64 * 1e-9);
            }
            if let Some(f) = opts.trajectory.as_mut() {
                let p = t.point_px.unwrap_or([f64::NAN; 2]);
                let b = rx.tracker().box_offset_px().unwrap_or([f64::NAN; 2]);
                writeln!(
                    f,
                    "{},{},{},{},{},{},{},{}",
                    frame.seq, frame.stamp_ns, p[0], p[1], t.reliable, t.features, b[0], b[1]
                )?;
            }
        }
        for t in &out.step.tokens {
            println!(
                "{:8.2} s {:7} {:?}",
                t.stamp_ns as f64 * 1e-9,
                t.token.label(),
                t.cause
            );
        }
        for f in &out.step.frames {
            println!(
                "RELEASED {:06b} at {:.2} s",
                f.payload,
                f.final_null_ns() as f64 * 1e-9
            );
        }
    }
    Ok(acquisitions)
}

/// Runs the ideal receiver on the ground-truth points and prints how far the RGB receiver's
/// tokens are from it.
fn compare_with_ideal(rx: &RgbReceiver, text: &str) -> Result<()> {
    let mut decoder = Decoder::new(SegmenterConfig::rgb())?;
    let mut tokens = Vec::new();
    for line in text.lines().filter(|l| !l.trim().is_empty()) {
        let v: Vec<&str> = line.split(',').collect();
        if v.len() < 4 {
            bail!("--ideal line {line:?}: want seq,stamp_ns,x_px,y_px");
        }
        let stamp_ns: u64 = v[1].trim().parse()?;
        let p = [v[2].trim().parse()?, v[3].trim().parse()?];
        tokens.extend(decoder.push(Sample::tracked(stamp_ns, p))?.tokens);
    }
    let ours = rx.tokens();
    let same =
        ours.len() == tokens.len() && ours.iter().zip(&tokens).all(|(a, b)| a.token == b.token);
    let worst_s = ours
        .iter()
        .zip(&tokens)
        .map(|(a, b)| a.stamp_ns.abs_diff(b.stamp_ns) as f64 * 1e-9)
        .fold(0.0, f64::max);
    if std::env::var_os("RGB_REPLAY_VERBOSE").is_some() {
        for (a, b) in ours.iter().zip(&tokens) {
            println!(
                "  {:6} {:9.2} s vs ideal {:6} {:9.2} s",
                a.token.label(),
                a.stamp_ns as f64 * 1e-9,
                b.token.label(),
                b.stamp_ns as f64 * 1e-9
            );
        }
    }
    println!(
        "ideal receiver: {} tokens, same sequence: {same}, worst token offset {worst_s:.3} s",
        tokens.len()
    );
    Ok(())
}
