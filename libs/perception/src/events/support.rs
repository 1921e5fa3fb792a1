//! Spatial event support inside a window of one packet: how many distinct pixels fired, how far
//! they spread, where their robust centre is, and how one-sided their polarity is.
//!
//! Support is counted in *unique pixels*, not events: a pixel that crosses the threshold several
//! times in one packet (a steep edge) is still one point of evidence about where the target is.
//! Polarity balance is counted in events, because that is what a flash or a disappearing target
//! skews.

use proto::EventPacket;

/// Percentiles whose bounds define the support centre (paper: 2.5th and 97.5th).
pub const LOWER_PERCENTILE: f64 = 0.025;
pub const UPPER_PERCENTILE: f64 = 0.975;

/// Where a support's centre is put.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Centre {
    /// The paper's: the midpoint of the 2.5th and 97.5th percentile bounds, per axis.
    #[default]
    PercentileMidpoint,
    /// The median, per axis: what a turning camera's support needs. Its ego-motion front end
    /// keeps or removes whole 16 px cells, so a static edge that crosses the target's cells
    /// (the floor's far edge behind a drone seen from above) is kept with it as a line a cell
    /// long; that line's few dozen pixels move the 97.5th percentile bound, and with it the
    /// midpoint, by up to half a cell, and barely move the median of the target's hundreds.
    Median,
}

/// An axis-aligned pixel window, `x0 ≤ x < x1`, `y0 ≤ y < y1`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Window {
    pub x0: u16,
    pub y0: u16,
    pub x1: u16,
    pub y1: u16,
}

impl Window {
    /// The whole sensor.
    pub fn full(width: u16, height: u16) -> Self {
        Self {
            x0: 0,
            y0: 0,
            x1: width,
            y1: height,
        }
    }

    /// The window of half-sizes `half_px` around `centre_px`, clipped to the sensor. A centre
    /// far outside the sensor gives an empty window, never a panic.
    pub fn centred(centre_px: [f64; 2], half_px: [f64; 2], width: u16, height: u16) -> Self {
        let clip = |v: f64, max: u16| -> u16 {
            if v.is_nan() {
                0
            } else {
                v.clamp(0.0, f64::from(max)) as u16
            }
        };
        let x0 = clip((centre_px[0] - half_px[0]).floor(), width);
        let x1 = clip((centre_px[0] + half_px[0]).ceil() + 1.0, width);
        let y0 = clip((centre_px[1] - half_px[1]).floor(), height);
        let y1 = clip((centre_px[1] + half_px[1]).ceil() + 1.0, height);
        Self {
            x0,
            y0,
            x1: x1.max(x0),
            y1: y1.max(y0),
        }
    }

    pub fn contains(&self, x: u16, y: u16) -> bool {
        x >= self.x0 && x < self.x1 && y >= self.y0 && y < self.y1
    }
}

/// The evidence one packet offers inside a window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Evidence {
    /// Events inside the window.
    pub events: usize,
    /// ON events among them.
    pub on_events: usize,
    /// Distinct pixels that fired inside the window.
    pub unique_pixels: usize,
    /// `max − min` of the unique pixels' x and y, pixels (0 for fewer than two).
    pub span_px: [u16; 2],
    /// Standard deviation of the unique pixels along their minor principal axis, pixels. Near
    /// zero for collinear support, whatever the line's direction.
    pub minor_spread_px: f64,
    /// Midpoint of the 2.5th / 97.5th percentile bounds of the unique pixels, per axis (pixel
    /// centres, i.e. `x + 0.5`). `None` without support.
    pub centre_px: Option<[f64; 2]>,
}

impl Evidence {
    /// No events at all.
    pub const EMPTY: Evidence = Evidence {
        events: 0,
        on_events: 0,
        unique_pixels: 0,
        span_px: [0, 0],
        minor_spread_px: 0.0,
        centre_px: None,
    };

    pub fn off_events(&self) -> usize {
        self.events - self.on_events
    }

    /// Share of the more frequent polarity, in [0.5, 1] (0 without events).
    pub fn majority_fraction(&self) -> f64 {
        if self.events == 0 {
            return 0.0;
        }
        self.on_events.max(self.off_events()) as f64 / self.events as f64
    }
}

/// Reusable buffers, sized to the sensor once: gathering allocates nothing per packet.
#[derive(Debug, Clone)]
pub struct SupportScratch {
    width: u16,
    height: u16,
    /// Generation stamp per pixel of the current window (row-major within the window): a pixel
    /// is already counted when it holds the current generation. Window-sized, so the local
    /// window's stamps stay in cache.
    seen: Vec<u32>,
    generation: u32,
    /// Unique pixels per window-relative column / row.
    hist_x: Vec<u32>,
    hist_y: Vec<u32>,
    cells: Vec<u32>,
    /// Column / row of the broad-activity grid for every x / y (cell size `cell_px`).
    cell_px: u16,
    cell_of_x: Vec<u32>,
    cell_of_y: Vec<u32>,
}

impl SupportScratch {
    pub fn new(width: u16, height: u16) -> Self {
        Self {
            width,
            height,
            seen: Vec::new(),
            generation: 0,
            hist_x: Vec::new(),
            hist_y: Vec::new(),
            cells: Vec::new(),
            cell_px: 0,
            cell_of_x: Vec::new(),
            cell_of_y: Vec::new(),
        }
    }

    fn next_generation(&mut self) -> u32 {
        self.generation = self.generation.wrapping_add(1);
        if self.generation == 0 {
            // Wrapped after 2^32 packets: old stamps could alias the new generation.
            self.seen.fill(0);
            self.generation = 1;
        }
        self.generation
    }
}

/// Gathers the evidence of `packet` inside `window`.
///
/// One pass over the events: unique pixels are marked in a window-sized stamp array and
/// accumulated into per-axis histograms (for the percentile bounds, O(events + window)) and
/// integer moment sums (for the principal spread). Events outside the sensor are ignored rather
/// than trusted.
pub fn gather(packet: &EventPacket, window: Window, scratch: &mut SupportScratch) -> Evidence {
    gather_centred(packet, window, Centre::PercentileMidpoint, scratch)
}

/// [`gather`] with the support's centre put by `rule`.
pub fn gather_centred(
    packet: &EventPacket,
    window: Window,
    rule: Centre,
    scratch: &mut SupportScratch,
) -> Evidence {
    let window = Window {
        x0: window.x0,
        y0: window.y0,
        x1: window.x1.min(scratch.width),
        y1: window.y1.min(scratch.height),
    };
    if packet.is_empty() || window.x0 >= window.x1 || window.y0 >= window.y1 {
        return Evidence::EMPTY;
    }
    let (w, h) = (
        usize::from(window.x1 - window.x0),
        usize::from(window.y1 - window.y0),
    );
    if scratch.seen.len() < w * h {
        // New stamps are 0, never a live generation (generations start at 1).
        scratch.seen.resize(w * h, 0);
    }
    let generation = scratch.next_generation();
    scratch.hist_x.clear();
    scratch.hist_x.resize(w, 0);
    scratch.hist_y.clear();
    scratch.hist_y.resize(h, 0);
    let (mut events, mut on_events) = (0usize, 0usize);
    // Moments of the window-relative coordinates of unique pixels.
    let (mut n, mut sx, mut sy, mut sxx, mut syy, mut sxy) = (0u64, 0u64, 0u64, 0u64, 0u64, 0u64);
    for (i, (&x, &y)) in packet.xs.iter().zip(&packet.ys).enumerate() {
        if !window.contains(x, y) {
            continue;
        }
        events += 1;
        if packet
            .on_bits
            .get(i / 8)
            .is_some_and(|b| b >> (i % 8) & 1 == 1)
        {
            on_events += 1;
        }
        let (rx, ry) = (usize::from(x - window.x0), usize::from(y - window.y0));
        let seen = &mut scratch.seen[ry * w + rx];
        if *seen != generation {
            *seen = generation;
            scratch.hist_x[rx] += 1;
            scratch.hist_y[ry] += 1;
            let (fx, fy) = (rx as u64, ry as u64);
            n += 1;
            sx += fx;
            sy += fy;
            sxx += fx * fx;
            syy += fy * fy;
            sxy += fx * fy;
        }
    }
    if n == 0 {
        return Evidence {
            events,
            on_events,
            ..Evidence::EMPTY
        };
    }
    let count = n as f64;
    let (mx, my) = (sx as f64 / count, sy as f64 / count);
    let var_x = sxx as f64 / count - mx * mx;
    let var_y = syy as f64 / count - my * my;
    let cov = sxy as f64 / count - mx * my;
    let minor_var = 0.5 * (var_x + var_y) - (0.25 * (var_x - var_y).powi(2) + cov * cov).sqrt();
    let lower = match rule {
        Centre::PercentileMidpoint => LOWER_PERCENTILE,
        Centre::Median => 0.5,
    };
    let (x_lo, x_hi, x_span) = percentile_bounds(&scratch.hist_x, n, lower);
    let (y_lo, y_hi, y_span) = percentile_bounds(&scratch.hist_y, n, lower);
    let centre =
        |lo: usize, hi: usize, origin: u16| 0.5 * (lo + hi) as f64 + f64::from(origin) + 0.5;
    Evidence {
        events,
        on_events,
        unique_pixels: n as usize,
        span_px: [x_span, y_span],
        minor_spread_px: minor_var.max(0.0).sqrt(),
        centre_px: Some([centre(x_lo, x_hi, window.x0), centre(y_lo, y_hi, window.y0)]),
    }
}

/// (`lower` percentile, `1 − lower` percentile, max − min) of the `n` (> 0) values counted in
/// `hist`, nearest rank (`lower` 0.5: the median twice).
fn percentile_bounds(hist: &[u32], n: u64, lower: f64) -> (usize, usize, u16) {
    let last = n - 1;
    let rank = |q: f64| ((q * last as f64).round() as u64).min(last);
    let upper = if lower == LOWER_PERCENTILE {
        UPPER_PERCENTILE
    } else {
        1.0 - lower
    };
    let (lo_rank, hi_rank) = (rank(lower), rank(upper));
    let (mut lo, mut hi) = (None, None);
    let mut below = 0u64;
    for (v, &c) in hist.iter().enumerate() {
        if c == 0 {
            continue;
        }
        below += u64::from(c);
        if lo.is_none() && below > lo_rank {
            lo = Some(v);
        }
        if below > hi_rank {
            hi = Some(v);
            break;
        }
    }
    let min = hist.iter().position(|&c| c > 0).unwrap_or(0);
    let max = hist.iter().rposition(|&c| c > 0).unwrap_or(0);
    (lo.unwrap_or(min), hi.unwrap_or(max), (max - min) as u16)
}

/// Number of `cell_px`-square cells of the sensor holding at least `min_events` events: a
/// coarse measure of how much of the scene is active, independent of the target window.
pub fn active_cells(
    packet: &EventPacket,
    cell_px: u16,
    min_events: u32,
    scratch: &mut SupportScratch,
) -> usize {
    let cell_px = cell_px.max(1);
    if scratch.cell_px != cell_px {
        // Lookup tables instead of a division per event.
        let cell = u32::from(cell_px);
        scratch.cell_px = cell_px;
        scratch.cell_of_x = (0..u32::from(scratch.width)).map(|x| x / cell).collect();
        scratch.cell_of_y = (0..u32::from(scratch.height)).map(|y| y / cell).collect();
    }
    let cols = u32::from(scratch.width).div_ceil(u32::from(cell_px));
    let rows = u32::from(scratch.height).div_ceil(u32::from(cell_px));
    scratch.cells.clear();
    scratch.cells.resize((cols * rows) as usize, 0);
    for (&x, &y) in packet.xs.iter().zip(&packet.ys) {
        if let (Some(&cx), Some(&cy)) = (
            scratch.cell_of_x.get(usize::from(x)),
            scratch.cell_of_y.get(usize::from(y)),
        ) {
            scratch.cells[(cy * cols + cx) as usize] += 1;
        }
    }
    scratch
        .cells
        .iter()
        .filter(|&&c| c >= min_events.max(1))
        .count()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::Polarity;

    fn packet(events: &[(u16, u16, Polarity)]) -> EventPacket {
        let events: Vec<_> = events.iter().map(|&(x, y, p)| (x, y, 1, p)).collect();
        EventPacket::from_events(0, (0, 40_000_000), (640, 480), &events)
    }

    /// A target of 48×12 pixels with a static edge kept beside it (a 30 px line leaving its
    /// right end, as a turning camera's front end keeps whole cells): the paper's midpoint
    /// follows the line by half its length, the median moves by the line's share of the pixels.
    #[test]
    fn the_median_centre_is_not_pulled_along_an_edge_beside_the_target() {
        let mut ev: Vec<_> = (0..48 * 12)
            .map(|i| (300 + i % 48, 230 + i / 48, Polarity::On))
            .collect();
        ev.extend((348..378).flat_map(|x| [(x, 229, Polarity::Off), (x, 228, Polarity::On)]));
        let mut scratch = SupportScratch::new(640, 480);
        let full = Window::full(640, 480);
        let target = [324.0, 236.0];
        let paper = gather(&packet(&ev), full, &mut scratch).centre_px.unwrap();
        let median = gather_centred(&packet(&ev), full, Centre::Median, &mut scratch)
            .centre_px
            .unwrap();
        assert!(paper[0] - target[0] > 10.0, "paper rule {paper:?}");
        assert!((median[0] - target[0]).abs() <= 3.0, "median {median:?}");
        assert!((median[1] - target[1]).abs() <= 2.0, "median {median:?}");
        // Without the edge both rules agree on the target's centre.
        ev.truncate(48 * 12);
        let paper = gather(&packet(&ev), full, &mut scratch).centre_px.unwrap();
        let median = gather_centred(&packet(&ev), full, Centre::Median, &mut scratch)
            .centre_px
            .unwrap();
        assert!((paper[0] - median[0]).abs() <= 1.0 && (paper[1] - median[1]).abs() <= 1.0);
    }

    #[test]
    fn centre_is_the_midpoint_of_percentile_bounds_not_the_mean() {
        // A 10x10 block of pixels at x 100..110, y 200..210, plus one far outlier pixel: the mean
        // moves, the percentile bounds do not.
        let mut ev: Vec<_> = (0..100)
            .map(|i| (100 + i % 10, 200 + i / 10, Polarity::On))
            .collect();
        ev.push((180, 260, Polarity::Off));
        let mut scratch = SupportScratch::new(640, 480);
        let e = gather(&packet(&ev), Window::full(640, 480), &mut scratch);
        assert_eq!(e.unique_pixels, 101);
        assert_eq!(e.events, 101);
        assert_eq!(e.on_events, 100);
        assert_eq!(e.span_px, [80, 60]);
        let c = e.centre_px.unwrap();
        assert_eq!(
            c,
            [105.0, 205.0],
            "bounds 100..109 → midpoint 104.5, pixel centre +0.5"
        );
    }

    #[test]
    fn repeated_pixels_count_once_for_support_but_every_event_counts_for_polarity() {
        let ev: Vec<_> = (0..30)
            .map(|i| (50 + (i % 3) as u16, 60, Polarity::Off))
            .collect();
        let mut scratch = SupportScratch::new(640, 480);
        let e = gather(&packet(&ev), Window::full(640, 480), &mut scratch);
        assert_eq!((e.events, e.unique_pixels, e.off_events()), (30, 3, 30));
        assert_eq!(e.majority_fraction(), 1.0);
        // Gathering again (new generation) sees the same, not zero, unique pixels.
        let again = gather(&packet(&ev), Window::full(640, 480), &mut scratch);
        assert_eq!(again.unique_pixels, 3);
    }

    #[test]
    fn collinear_support_has_no_minor_spread_in_any_direction() {
        let diagonal: Vec<_> = (0..40).map(|i| (100 + i, 100 + i, Polarity::On)).collect();
        let mut scratch = SupportScratch::new(640, 480);
        let e = gather(&packet(&diagonal), Window::full(640, 480), &mut scratch);
        assert_eq!(e.span_px, [39, 39], "a diagonal passes an axis-span test");
        assert!(
            e.minor_spread_px < 1e-6,
            "but has no width: {}",
            e.minor_spread_px
        );
        let blob: Vec<_> = (0..40)
            .map(|i| (100 + i % 8, 100 + i / 8, Polarity::On))
            .collect();
        let b = gather(&packet(&blob), Window::full(640, 480), &mut scratch);
        assert!(b.minor_spread_px > 1.0, "{}", b.minor_spread_px);
    }

    #[test]
    fn window_limits_the_evidence_and_clips_to_the_sensor() {
        let ev = [
            (10, 10, Polarity::On),
            (300, 200, Polarity::Off),
            (639, 479, Polarity::On),
        ];
        let mut scratch = SupportScratch::new(640, 480);
        let w = Window::centred([300.0, 200.0], [5.0, 5.0], 640, 480);
        let e = gather(&packet(&ev), w, &mut scratch);
        assert_eq!((e.events, e.unique_pixels), (1, 1));
        let corner = Window::centred([680.0, 520.0], [80.0, 80.0], 640, 480);
        assert!(corner.contains(639, 479));
        assert_eq!((corner.x1, corner.y1), (640, 480));
        let outside = Window::centred([-500.0, f64::NAN], [10.0, 10.0], 640, 480);
        assert_eq!(gather(&packet(&ev), outside, &mut scratch), Evidence::EMPTY);
    }

    #[test]
    fn active_cells_counts_coarse_cells_with_enough_events() {
        let mut ev = Vec::new();
        for cell in 0..20u16 {
            for k in 0..4 {
                ev.push((cell * 32 + k, 5, Polarity::On));
            }
        }
        ev.push((5, 400, Polarity::On)); // a single event is not an active cell
        let mut scratch = SupportScratch::new(640, 480);
        assert_eq!(active_cells(&packet(&ev), 32, 4, &mut scratch), 20);
        assert_eq!(active_cells(&packet(&ev), 32, 5, &mut scratch), 0);
    }
}
