//! Replays a directory of 25 Hz RGB PNG frames (sorted by name, frame k stamped (k + 1) · 40 ms)
//! through the RGB receiver and prints its tokens and released frames.
//!
//! `cargo run --release -p observer-node --example rgb_replay -- DIR [--trajectory OUT.csv]
//!  [--drop FIRST:COUNT]`
//!
//! `--drop` withholds COUNT frames starting at index FIRST (a sequence gap); `--trajectory`
//! writes `seq,stamp_ns,x_px,y_px,reliable,features` per frame.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use observer_node::rgb::{RgbReceiver, TrackEvent};
use proto::RgbFrame;

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

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let dir = PathBuf::from(
        args.next()
            .context("usage: DIR [--trajectory OUT.csv] [--drop FIRST:COUNT]")?,
    );
    let mut trajectory: Option<std::fs::File> = None;
    let mut drop = 0..0;
    while let Some(a) = args.next() {
        match a.as_str() {
            "--trajectory" => {
                let p = args.next().context("--trajectory needs a path")?;
                trajectory =
                    Some(std::fs::File::create(&p).with_context(|| format!("creating {p}"))?);
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
    let mut paths: Vec<PathBuf> = std::fs::read_dir(&dir)
        .with_context(|| format!("listing {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
        .collect();
    paths.sort();
    let mut rx = RgbReceiver::paper();
    let started = std::time::Instant::now();
    let mut acquisitions = 0;
    for (k, path) in paths.iter().enumerate() {
        if drop.contains(&k) {
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
            if let Some(f) = trajectory.as_mut() {
                let p = t.point_px.unwrap_or([f64::NAN; 2]);
                writeln!(
                    f,
                    "{},{},{},{},{},{}",
                    frame.seq, frame.stamp_ns, p[0], p[1], t.reliable, t.features
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
    let wall = started.elapsed().as_secs_f64();
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
