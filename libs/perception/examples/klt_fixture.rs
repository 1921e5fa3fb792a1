//! Records the KLT comparison fixture: real MuJoCo renders of the performer flying the START
//! symbol, seen by every observer's camera, as the grey frames the RGB tracker works on, plus
//! the points our tracker holds before each frame (what it tracks into that frame).
//!
//! `cargo run --release -p perception --example klt_fixture [-- --out DIR]`
//! (default `libs/perception/tests/fixtures/klt`).
//!
//! The flight is the link harness's (`waggle link`): one offer of payload 011010 after a 1 s
//! lead-in, the performer following its schedule in 500 Hz physics, each observer rendered at
//! 25 Hz. Every observer's frames go through our `TargetTracker` from the first frame on, so the
//! recorded points are exactly the ones the receiver tracks (plus a grid of probes around the
//! target, see `Pair::probes_px`). One clip per observer of
//! `--frames` consecutive frames is kept, starting `--offset-ms` after the START stroke begins.
//! The run is deterministic: re-running it reproduces the files byte for byte on the same
//! machine (MuJoCo physics and Mesa's rasteriser are deterministic for the same state).
//!
//! Output: `DIR/O<i>/f<k>.png` (8-bit grey, the receiver's luma of the RGB render) and
//! `DIR/fixture.json` (clips, frame files, timestamps and per-pair points).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use image::GrayImage;
use perception::rgb::features::Region;
use perception::rgb::{RgbReceiverConfig, TargetTracker};
use proto::Action;
use proto::scene::observer_name;
use proto::{TruthSymbol, paper_broadcast};
use serde::Serialize;
use sim::control::Reference;
use sim::render::CameraRenderer;
use sim::world::World;

const OBSERVERS: usize = 3;
const PAYLOAD: u8 = 0b011010;
const LEAD_IN_NS: u64 = 1_000_000_000;
const FRAME_PERIOD_NS: u64 = 40_000_000;

#[derive(Serialize)]
struct Pair {
    /// Indices into the clip's frames.
    prev: usize,
    next: usize,
    /// Our tracker's features in `prev` (pixel-centre coordinates).
    points_px: Vec<[f32; 2]>,
    /// Probes: a 5 × 3 grid over the target box and 8 px beyond it, off the pixel grid, so that
    /// the comparison also covers flat wall, edges and partial views, where the two libraries'
    /// statuses can differ (the receiver never tracks such points: they are not features).
    probes_px: Vec<[f32; 2]>,
}

#[derive(Serialize)]
struct Clip {
    observer: String,
    frames: Vec<String>,
    stamps_ns: Vec<u64>,
    pairs: Vec<Pair>,
}

#[derive(Serialize)]
struct Fixture {
    generator: String,
    payload: String,
    width_px: u32,
    height_px: u32,
    clips: Vec<Clip>,
}

fn luma(rgb: &[u8], w: u32, h: u32) -> GrayImage {
    let data = rgb
        .chunks_exact(3)
        .map(|p| perception::rgb::luma::luma(p[0], p[1], p[2]))
        .collect();
    GrayImage::from_raw(w, h, data).expect("render size")
}

/// A 5 × 3 grid spanning `b` and `PROBE_MARGIN_PX` beyond it, shifted off the pixel grid.
fn probes(b: Region) -> Vec<[f32; 2]> {
    const PROBE_MARGIN_PX: f32 = 8.0;
    let (x0, x1) = (b.x0 as f32 - PROBE_MARGIN_PX, b.x1 as f32 + PROBE_MARGIN_PX);
    let (y0, y1) = (b.y0 as f32 - PROBE_MARGIN_PX, b.y1 as f32 + PROBE_MARGIN_PX);
    let mut out = Vec::new();
    for j in 0..3 {
        for i in 0..5 {
            out.push([
                x0 + (x1 - x0) * i as f32 / 4.0 + 0.37,
                y0 + (y1 - y0) * j as f32 / 2.0 + 0.61,
            ]);
        }
    }
    out
}

fn write_png(path: &Path, img: &GrayImage) -> Result<()> {
    let file =
        std::fs::File::create(path).with_context(|| format!("creating {}", path.display()))?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), img.width(), img.height());
    enc.set_color(png::ColorType::Grayscale);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_compression(png::Compression::High);
    let mut writer = enc.write_header()?;
    writer.write_image_data(img.as_raw())?;
    writer.finish()?;
    Ok(())
}

fn main() -> Result<()> {
    let mut out = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/klt"));
    let mut frames = 40usize;
    let mut offset_ms = 600u64;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut value = || args.next().with_context(|| format!("{a} needs a value"));
        match a.as_str() {
            "--out" => out = PathBuf::from(value()?),
            "--frames" => frames = value()?.parse()?,
            "--offset-ms" => offset_ms = value()?.parse()?,
            other => bail!("unknown argument {other} (have --out, --frames, --offset-ms)"),
        }
    }
    if frames < 2 {
        bail!("--frames must be at least 2");
    }
    let schedule = paper_broadcast(LEAD_IN_NS, &[PAYLOAD], false)?;
    let start_ns = schedule
        .timeline()
        .iter()
        .find(|s| s.symbol == TruthSymbol::Action(Action::Start))
        .context("the broadcast has no START")?
        .start_ns;
    // First frame of the clip, on the 25 Hz grid.
    let clip_first_ns =
        (start_ns + offset_ms * 1_000_000).div_ceil(FRAME_PERIOD_NS) * FRAME_PERIOD_NS;
    let clip_last_ns = clip_first_ns + (frames as u64 - 1) * FRAME_PERIOD_NS;

    let config = RgbReceiverConfig::paper();
    let mut trackers = (0..OBSERVERS)
        .map(|_| TargetTracker::new(config.tracker, config.klt, config.features))
        .collect::<Result<Vec<_>, _>>()?;
    let mut clips: Vec<Clip> = (0..OBSERVERS)
        .map(|i| Clip {
            observer: observer_name(i),
            frames: Vec::new(),
            stamps_ns: Vec::new(),
            pairs: Vec::new(),
        })
        .collect();
    for c in &clips {
        std::fs::create_dir_all(out.join(&c.observer))
            .with_context(|| format!("creating {}", out.display()))?;
    }

    let mut world = World::new(OBSERVERS).context("building the scene")?;
    let mut renderer = CameraRenderer::new(&world, sim::render::RenderPath::default())
        .context("creating the offscreen renderer")?;
    let (w, h) = (
        u32::from(proto::scene::IMAGE_WIDTH_PX),
        u32::from(proto::scene::IMAGE_HEIGHT_PX),
    );
    while world.time_ns() < clip_last_ns {
        let sp = schedule.state_at(world.time_ns());
        world.set_reference(0, Reference::new(sp, 0.0));
        world.step();
        let t = world.time_ns();
        if !t.is_multiple_of(FRAME_PERIOD_NS) {
            continue;
        }
        for (i, (tracker, clip)) in trackers.iter_mut().zip(&mut clips).enumerate() {
            let grey = luma(renderer.render(&mut world, i)?, w, h);
            if t >= clip_first_ns {
                let k = clip.frames.len();
                if let (true, Some(b)) = (k > 0, tracker.target_box(w, h)) {
                    clip.pairs.push(Pair {
                        prev: k - 1,
                        next: k,
                        points_px: tracker.features().to_vec(),
                        probes_px: probes(b),
                    });
                }
                let name = format!("{}/f{k:03}.png", clip.observer);
                write_png(&out.join(&name), &grey)?;
                clip.frames.push(name);
                clip.stamps_ns.push(t);
            }
            tracker.step(&grey);
        }
    }
    for c in &clips {
        let points: usize = c.pairs.iter().map(|p| p.points_px.len()).sum();
        let probes: usize = c.pairs.iter().map(|p| p.probes_px.len()).sum();
        println!(
            "{}: {} frames, {} pairs, {points} points, {probes} probes",
            c.observer,
            c.frames.len(),
            c.pairs.len()
        );
    }
    let fixture = Fixture {
        generator: format!(
            "cargo run --release -p perception --example klt_fixture -- --frames {frames} \
             --offset-ms {offset_ms}"
        ),
        payload: format!("{PAYLOAD:06b}"),
        width_px: w,
        height_px: h,
        clips,
    };
    let path = out.join("fixture.json");
    std::fs::write(&path, serde_json::to_string(&fixture)? + "\n")
        .with_context(|| format!("writing {}", path.display()))?;
    println!("wrote {}", path.display());
    Ok(())
}
