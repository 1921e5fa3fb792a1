//! The synthetic event camera offline (`waggle events convert`): a directory of PNG frames →
//! an event list (CSV).
//!
//! Frames are the PNG files of the directory sorted by file name, frame k stamped
//! `k·10⁹/fps` ns (integer, rounded down) from the first. Output: a header `t_ns,x,y,p` and one
//! line per event in converter order (time, then pixel index), `p` = 1 (ON) or −1 (OFF). The
//! CSV is written to a temporary file next to the target and renamed on success, so a failed
//! run never leaves a truncated event list behind.

use std::fs;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use event_camera::picture::decode_png;
use event_camera::{Converter, Event, Polarity};

/// What to convert.
#[derive(Debug, Clone)]
pub struct ConvertOptions {
    /// Frame rate of the input frames, Hz (at least 1).
    pub fps: u32,
    /// Directory of PNG frames.
    pub input: PathBuf,
    /// Output CSV file.
    pub out: PathBuf,
    /// Contrast threshold C in log intensity.
    pub threshold: f64,
}

/// Counts reported after a conversion (its `Display` is the line `waggle events convert`
/// prints).
pub struct Summary {
    frames: usize,
    width: u16,
    height: u16,
    on: u64,
    off: u64,
    /// Converter time over the frames after the first (which only initialises).
    converting: Duration,
    out: PathBuf,
}

impl std::fmt::Display for Summary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let intervals = self.frames.saturating_sub(1).max(1) as f64;
        write!(
            f,
            "{} frames {}x{}: {} events (ON {}, OFF {}) -> {}; {:.3} ms per frame converting",
            self.frames,
            self.width,
            self.height,
            self.on + self.off,
            self.on,
            self.off,
            self.out.display(),
            self.converting.as_secs_f64() * 1e3 / intervals,
        )
    }
}

/// The PNG files of `dir`, sorted by file name.
pub(crate) fn frame_paths(dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let entries = fs::read_dir(dir)
        .with_context(|| format!("cannot read frames directory {}", dir.display()))?;
    let mut paths = Vec::new();
    for entry in entries {
        let path = entry
            .with_context(|| format!("cannot list {}", dir.display()))?
            .path();
        if path.is_file()
            && path
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("png"))
        {
            paths.push(path);
        }
    }
    paths.sort_by(|a, b| a.file_name().cmp(&b.file_name()));
    if paths.is_empty() {
        bail!("no PNG frames (*.png) in {}", dir.display());
    }
    Ok(paths)
}

/// Stamp of frame `k` at `fps`, nanoseconds from the first frame.
pub(crate) fn stamp_ns(k: usize, fps: u32) -> u64 {
    (k as u128 * 1_000_000_000 / u128::from(fps)) as u64
}

/// Converts the frames into the CSV, atomically (a temporary file renamed on success).
pub fn convert(args: &ConvertOptions) -> anyhow::Result<Summary> {
    let paths = frame_paths(&args.input)?;
    let mut partial = args.out.clone().into_os_string();
    partial.push(".partial");
    let partial = PathBuf::from(partial);
    let result = convert_into(args, &paths, &partial);
    match result {
        Ok(summary) => {
            fs::rename(&partial, &args.out).with_context(|| {
                format!(
                    "cannot move {} to {}",
                    partial.display(),
                    args.out.display()
                )
            })?;
            Ok(summary)
        }
        Err(e) => {
            // Best effort: the error being reported matters more than a failed clean-up.
            let _ = fs::remove_file(&partial);
            Err(e)
        }
    }
}

fn convert_into(args: &ConvertOptions, paths: &[PathBuf], csv: &Path) -> anyhow::Result<Summary> {
    let file = fs::File::create(csv).with_context(|| format!("cannot create {}", csv.display()))?;
    let mut writer = BufWriter::new(file);
    let write_failed = || format!("cannot write {}", csv.display());
    writeln!(writer, "t_ns,x,y,p").with_context(write_failed)?;
    let mut converter: Option<Converter> = None;
    let mut events: Vec<Event> = Vec::new();
    let (mut on, mut off) = (0u64, 0u64);
    let mut converting = Duration::ZERO;
    for (k, path) in paths.iter().enumerate() {
        let bytes = fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
        let image =
            decode_png(&bytes).with_context(|| format!("cannot decode PNG {}", path.display()))?;
        let converter = match &mut converter {
            Some(c) => {
                let (w, h) = (u32::from(c.width()), u32::from(c.height()));
                if (image.width(), image.height()) != (w, h) {
                    bail!(
                        "{} is {}x{}, but the first frame {} is {w}x{h}",
                        path.display(),
                        image.width(),
                        image.height(),
                        paths[0].display()
                    );
                }
                c
            }
            None => {
                let (Ok(w), Ok(h)) = (u16::try_from(image.width()), u16::try_from(image.height()))
                else {
                    bail!(
                        "{} is {}x{}: too large",
                        path.display(),
                        image.width(),
                        image.height()
                    );
                };
                converter.insert(
                    Converter::new(w, h, args.threshold)
                        .with_context(|| format!("cannot convert {}", path.display()))?,
                )
            }
        };
        events.clear();
        let started = Instant::now();
        converter
            .push(stamp_ns(k, args.fps), image.as_raw(), &mut events)
            .with_context(|| format!("cannot convert {}", path.display()))?;
        if k > 0 {
            converting += started.elapsed();
        }
        for e in &events {
            let p = match e.polarity {
                Polarity::On => {
                    on += 1;
                    1
                }
                Polarity::Off => {
                    off += 1;
                    -1
                }
            };
            writeln!(writer, "{},{},{},{p}", e.t_ns, e.x, e.y).with_context(write_failed)?;
        }
    }
    writer.flush().with_context(write_failed)?;
    let converter = converter.context("no frame was converted")?;
    Ok(Summary {
        frames: paths.len(),
        width: converter.width(),
        height: converter.height(),
        on,
        off,
        converting,
        out: args.out.clone(),
    })
}
