//! `waggle viewpoints`: decode success against viewing angle and distance.
//!
//! Each point of the grid is one observer placed at (azimuth from the gesture plane's normal,
//! elevation, distance) and aimed at the performer; up to eight points share one flight of the
//! link harness (observers are hidden from each other's cameras, so they do not interfere). A
//! point succeeds when its observer released exactly the broadcast payloads, in order.

use std::collections::BTreeMap;
use std::time::Instant;

use anyhow::{Result, bail};
use proto::scene::{MAX_OBSERVERS, Placement};
use proto::{Receiver, Rectification, RenderPath};
use serde::Serialize;

use crate::harness::link::{LinkOptions, fly_link};

/// The grid to measure.
#[derive(Debug, Clone)]
pub struct ViewpointOptions {
    pub azimuths_deg: Vec<f64>,
    pub elevation_deg: f64,
    pub distances_m: Vec<f64>,
    pub receivers: Vec<Receiver>,
    pub rectifications: Vec<Rectification>,
    pub payloads: Vec<u8>,
    pub render: RenderPath,
}

/// One measured point.
#[derive(Debug, Clone, Serialize)]
pub struct ViewpointResult {
    pub receiver: String,
    pub rectification: String,
    pub azimuth_deg: f64,
    pub elevation_deg: f64,
    pub distance_m: f64,
    /// Released payloads, as six-bit strings.
    pub released: Vec<String>,
    pub success: bool,
}

/// Everything `waggle viewpoints --json` prints.
#[derive(Debug, Serialize)]
pub struct ViewpointsOut {
    pub payloads: Vec<String>,
    pub results: Vec<ViewpointResult>,
    pub wall_seconds: f64,
}

/// Runs the grid, calling `progress(done, total)` after each flight.
pub fn measure(
    opts: &ViewpointOptions,
    mut progress: impl FnMut(usize, usize),
) -> Result<ViewpointsOut> {
    if opts.payloads.is_empty() {
        bail!("at least one --payload is needed to measure decoding");
    }
    let started = Instant::now();
    let want: Vec<String> = opts.payloads.iter().map(|p| format!("{p:06b}")).collect();
    let mut flights = Vec::new();
    for &receiver in &opts.receivers {
        for &rectification in &opts.rectifications {
            for &distance_m in &opts.distances_m {
                for chunk in opts.azimuths_deg.chunks(MAX_OBSERVERS) {
                    flights.push((receiver, rectification, distance_m, chunk.to_vec()));
                }
            }
        }
    }
    let total = flights.len();
    let mut results = Vec::new();
    for (k, (receiver, rectification, distance_m, azimuths)) in flights.into_iter().enumerate() {
        let out = fly_link(&LinkOptions {
            events_raw: None,
            observers: azimuths.len(),
            modality: receiver,
            payloads: opts.payloads.clone(),
            no_acquisition: false,
            hover_s: 0.0,
            black: Vec::new(),
            render: opts.render,
            viewpoints: azimuths
                .iter()
                .map(|&az| Placement::viewpoint(az, opts.elevation_deg, distance_m))
                .collect(),
            rectification,
            frame_check: proto::FrameCheck::None,
        })?;
        for (i, (_, o)) in out.observers.iter().enumerate() {
            results.push(ViewpointResult {
                receiver: receiver.to_string(),
                rectification: rectification.to_string(),
                azimuth_deg: azimuths[i],
                elevation_deg: opts.elevation_deg,
                distance_m,
                released: o.payloads.clone(),
                success: o.payloads == want,
            });
        }
        progress(k + 1, total);
    }
    Ok(ViewpointsOut {
        payloads: want,
        results,
        wall_seconds: started.elapsed().as_secs_f64(),
    })
}

/// Markdown table: one row per (distance, azimuth), one column per receiver × rectification;
/// ✓ decoded every payload, ✗ did not (with what was released).
pub fn markdown(out: &ViewpointsOut) -> String {
    let mut columns: Vec<(String, String)> = Vec::new();
    let mut cells: BTreeMap<(u64, i64), BTreeMap<(String, String), String>> = BTreeMap::new();
    for r in &out.results {
        let col = (r.receiver.clone(), r.rectification.clone());
        if !columns.contains(&col) {
            columns.push(col.clone());
        }
        let cell = if r.success {
            "✓".to_owned()
        } else if r.released.is_empty() {
            "✗".to_owned()
        } else {
            format!("✗ ({})", r.released.join(" "))
        };
        let row = (
            (r.distance_m * 1000.0).round() as u64,
            (r.azimuth_deg * 10.0).round() as i64,
        );
        cells.entry(row).or_default().insert(col, cell);
    }
    let mut s = String::from("| distance | azimuth |");
    for (rx, rect) in &columns {
        s.push_str(&format!(" {rx} ({rect}) |"));
    }
    s.push_str("\n| ---: | ---: |");
    for _ in &columns {
        s.push_str(" :---: |");
    }
    s.push('\n');
    for ((mm, az10), row) in &cells {
        s.push_str(&format!(
            "| {:.1} m | {:.0}° |",
            *mm as f64 / 1000.0,
            *az10 as f64 / 10.0
        ));
        for col in &columns {
            s.push_str(&format!(" {} |", row.get(col).map_or("", String::as_str)));
        }
        s.push('\n');
    }
    s
}
