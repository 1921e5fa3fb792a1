//! The sensor model run backwards: the terms of [`crate::EventNoise`] measured from a recording
//! of a real camera (`waggle sensor-fit`).
//!
//! The background is either every event of a stretch where nothing in view moved, or, without
//! one, the events with no event at any of the 8 neighbouring pixels within
//! [`NEIGHBOUR_WINDOW_NS`] before or after (the test denoising work uses to tell noise from
//! signal). A noise event also has such a neighbour by chance, with probability
//! `1 − exp(−8·r·2τ)` at background rate `r` and window `τ`, so the isolated rate `r_iso`
//! underestimates `r`; the fit solves `r_iso = r·exp(−16·r·τ)` for `r` (the smaller root).
//!
//! From the background's per-pixel counts over its duration `T`:
//! * **hot pixels**: pixels with at least [`HOT_MIN_EVENTS`] events and at least
//!   [`HOT_FACTOR`] times the mean count of the others (found by iterating to a fixed point);
//! * **shot noise**: fair polarity, so twice the OFF rate of the other pixels;
//! * **leak**: ON events only, so the ON rate minus the OFF rate (0 when negative);
//! * **spread**: the excess of the counts' variance over a Poisson process's, as a lognormal
//!   spread of the pixels' rates in decades (reported; Waggle's model spreads only the leak).
//!
//! The spread is also given per polarity (ON counts alone, OFF counts alone).
//!
//! From every event (signal included): the **refractory floor**, the 0.1 % quantile of the
//! intervals between consecutive events of one pixel.
//!
//! From the signal (the events that have a neighbour, at pixels that are not hot): **events per
//! edge crossing**, by polarity. An edge passing a pixel makes a run of events of one polarity,
//! each within [`CROSSING_GAP_NS`] of the one before; a sharp edge of log contrast `c` makes
//! `⌊c / threshold⌋` of them, so the mean run tells contrast from threshold when one is known.

use crate::event::{Event, Polarity};

/// Neighbour window τ of the no-static-stretch background, ns.
pub const NEIGHBOUR_WINDOW_NS: u64 = 10_000_000;
/// A hot pixel has at least this many events in the background...
pub const HOT_MIN_EVENTS: u64 = 20;
/// ...and at least this multiple of the mean count of the other pixels.
pub const HOT_FACTOR: f64 = 10.0;
/// Quantile of the same-pixel intervals taken as the refractory floor.
pub const REFRACTORY_QUANTILE: f64 = 0.001;
/// Fewest same-pixel intervals for a refractory floor to be reported.
pub const MIN_INTERVALS: usize = 1000;
/// Longest interval between two events of one edge crossing at one pixel, ns.
pub const CROSSING_GAP_NS: u64 = 10_000_000;
/// Fewest crossings of a polarity for its events per crossing to be reported.
pub const MIN_CROSSINGS: u64 = 100;

/// How the background was told from the signal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Background {
    /// Every event in `[start_ns, end_ns)` (times as recorded).
    Static { start_ns: u64, end_ns: u64 },
    /// Isolated events over the whole recording, corrected for chance neighbours.
    Isolated,
}

impl Background {
    /// The stretch `window_s` (seconds from the recording's first event at `first_ns`), or
    /// the isolated events without one.
    pub fn from_window(first_ns: u64, window_s: Option<(f64, f64)>) -> Self {
        match window_s {
            Some((start_s, end_s)) => Background::Static {
                start_ns: first_ns.saturating_add((start_s * 1e9) as u64),
                end_ns: first_ns.saturating_add((end_s * 1e9) as u64),
            },
            None => Background::Isolated,
        }
    }
}

/// What a recording says of its sensor's terms.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorFit {
    pub width: u16,
    pub height: u16,
    pub background: Background,
    /// Duration of the background, s.
    pub duration_s: f64,
    /// Background events counted (isolated ones, without a static stretch).
    pub background_events: u64,
    /// Mean ON and OFF rates of the pixels that are not hot, Hz per pixel (corrected).
    pub on_hz: f64,
    pub off_hz: f64,
    /// `2·off_hz`: the shot noise term.
    pub shot_noise_hz: f64,
    /// `max(on_hz − off_hz, 0)`: the leak term.
    pub leak_hz: f64,
    /// Lognormal spread of the pixels' background rates, decades (0 when the counts vary no
    /// more than a Poisson process's).
    pub rate_spread_decades: f64,
    /// The same spread from the ON counts alone and from the OFF counts alone, decades.
    pub on_spread_decades: f64,
    pub off_spread_decades: f64,
    /// Hot pixels (x, y), sorted, and their median rate, Hz.
    pub hot_pixels: Vec<(u16, u16)>,
    pub hot_pixel_hz: f64,
    /// The refractory floor, ns (None: fewer than [`MIN_INTERVALS`] intervals).
    pub refractory_floor_ns: Option<u64>,
    /// Edge crossings found in the signal, and their mean events by polarity (None: fewer than
    /// [`MIN_CROSSINGS`] of that polarity).
    pub crossings: Crossings,
}

/// Runs of one polarity at one pixel in the signal: what an edge passing it makes.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Crossings {
    pub on_crossings: u64,
    pub off_crossings: u64,
    pub on_events_per_crossing: Option<f64>,
    pub off_events_per_crossing: Option<f64>,
}

/// Why a recording cannot be fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitError {
    #[error("the sensor is {width}×{height}: nothing to measure")]
    EmptySensor { width: u16, height: u16 },
    #[error("the background has no duration (its events span {span_ns} ns)")]
    NoDuration { span_ns: u64 },
    #[error("event {index} at ({x}, {y}) lies outside the {width}×{height} sensor")]
    OffSensor {
        index: usize,
        x: u16,
        y: u16,
        width: u16,
        height: u16,
    },
    #[error("event {index} comes before the one preceding it ({t_ns} ns < {previous_ns} ns)")]
    NotInTimeOrder {
        index: usize,
        t_ns: u64,
        previous_ns: u64,
    },
}

/// Fits `events` (time-ordered) of a `width`×`height` sensor.
pub fn fit(
    events: &[Event],
    width: u16,
    height: u16,
    background: Background,
) -> Result<SensorFit, FitError> {
    if width == 0 || height == 0 {
        return Err(FitError::EmptySensor { width, height });
    }
    let (w, n) = (usize::from(width), usize::from(width) * usize::from(height));
    let mut previous_ns = 0;
    for (index, e) in events.iter().enumerate() {
        if e.x >= width || e.y >= height {
            return Err(FitError::OffSensor {
                index,
                x: e.x,
                y: e.y,
                width,
                height,
            });
        }
        if e.t_ns < previous_ns {
            return Err(FitError::NotInTimeOrder {
                index,
                t_ns: e.t_ns,
                previous_ns,
            });
        }
        previous_ns = e.t_ns;
    }
    let pixel = |e: &Event| usize::from(e.y) * w + usize::from(e.x);
    let (first, last) = (
        events.first().map_or(0, |e| e.t_ns),
        events.last().map_or(0, |e| e.t_ns),
    );
    let alone = isolated(events, width, height);
    let (keep, duration_ns): (Vec<bool>, u64) = match background {
        Background::Static { start_ns, end_ns } => (
            events
                .iter()
                .map(|e| (start_ns..end_ns).contains(&e.t_ns))
                .collect(),
            end_ns.saturating_sub(start_ns),
        ),
        Background::Isolated => (alone.clone(), last - first),
    };
    if duration_ns == 0 {
        return Err(FitError::NoDuration {
            span_ns: last - first,
        });
    }
    let duration_s = duration_ns as f64 * 1e-9;
    let (mut on, mut off) = (vec![0u64; n], vec![0u64; n]);
    for (e, _) in events.iter().zip(&keep).filter(|(_, k)| **k) {
        match e.polarity {
            Polarity::On => on[pixel(e)] += 1,
            Polarity::Off => off[pixel(e)] += 1,
        }
    }
    let total: Vec<u64> = on.iter().zip(&off).map(|(a, b)| a + b).collect();
    let hot = hot_pixels(&total);
    let cold = n - hot.len();
    let is_hot = {
        let mut flags = vec![false; n];
        hot.iter().for_each(|&i| flags[i] = true);
        flags
    };
    let sum = |counts: &[u64]| {
        counts
            .iter()
            .zip(&is_hot)
            .filter(|(_, h)| !**h)
            .map(|(c, _)| *c)
            .sum::<u64>()
    };
    let rate = |count: u64| count as f64 / (cold.max(1) as f64 * duration_s);
    let (mut on_hz, mut off_hz) = (rate(sum(&on)), rate(sum(&off)));
    // Without a static stretch, every pixel's events are thinned by the same chance of a
    // neighbour: the background's, hot pixels' included.
    let mut gain = 1.0;
    if background == Background::Isolated {
        let all = on_hz + off_hz;
        if all > 0.0 {
            gain = uncorrect(all, NEIGHBOUR_WINDOW_NS as f64 * 1e-9) / all;
            (on_hz, off_hz) = (on_hz * gain, off_hz * gain);
        }
    }
    let mut hot_rates: Vec<f64> = hot
        .iter()
        .map(|&i| gain * total[i] as f64 / duration_s)
        .collect();
    hot_rates.sort_by(f64::total_cmp);
    let mut hot_pixels: Vec<(u16, u16)> = hot
        .iter()
        .map(|&i| ((i % w) as u16, (i / w) as u16))
        .collect();
    hot_pixels.sort_unstable();
    Ok(SensorFit {
        width,
        height,
        background,
        duration_s,
        background_events: keep.iter().filter(|k| **k).count() as u64,
        on_hz,
        off_hz,
        shot_noise_hz: 2.0 * off_hz,
        leak_hz: (on_hz - off_hz).max(0.0),
        rate_spread_decades: spread_decades(&total, &is_hot),
        on_spread_decades: spread_decades(&on, &is_hot),
        off_spread_decades: spread_decades(&off, &is_hot),
        hot_pixel_hz: hot_rates.get(hot_rates.len() / 2).copied().unwrap_or(0.0),
        hot_pixels,
        refractory_floor_ns: refractory_floor(events, n, pixel),
        crossings: crossings(events, &alone, &is_hot, pixel),
    })
}

/// Runs of one polarity at one pixel among the signal events (not `alone`, not hot), each
/// event within [`CROSSING_GAP_NS`] of the one before; a background event at the pixel does not
/// break a run (it is noise beside the edge, not a new one).
fn crossings(
    events: &[Event],
    alone: &[bool],
    is_hot: &[bool],
    pixel: impl Fn(&Event) -> usize,
) -> Crossings {
    // Per pixel: the last signal event's time and polarity (None: no run open).
    let mut open: Vec<Option<(u64, Polarity)>> = vec![None; is_hot.len()];
    let (mut runs, mut run_events) = ([0u64; 2], [0u64; 2]);
    let slot = |p: Polarity| usize::from(p == Polarity::Off);
    for (e, _) in events.iter().zip(alone).filter(|(_, a)| !**a) {
        let i = pixel(e);
        if is_hot[i] {
            continue;
        }
        let continues = matches!(open[i], Some((t, p)) if p == e.polarity
            && e.t_ns - t <= CROSSING_GAP_NS);
        if !continues {
            runs[slot(e.polarity)] += 1;
        }
        run_events[slot(e.polarity)] += 1;
        open[i] = Some((e.t_ns, e.polarity));
    }
    let mean = |k: usize| (runs[k] >= MIN_CROSSINGS).then(|| run_events[k] as f64 / runs[k] as f64);
    Crossings {
        on_crossings: runs[0],
        off_crossings: runs[1],
        on_events_per_crossing: mean(0),
        off_events_per_crossing: mean(1),
    }
}

/// Per event: no event at any of the 8 neighbours within the window before or after it.
pub(crate) fn isolated(events: &[Event], width: u16, height: u16) -> Vec<bool> {
    let (w, h) = (usize::from(width), usize::from(height));
    let mut isolated = vec![true; events.len()];
    let mut last = vec![u64::MAX; w * h];
    let mut pass = |order: &mut dyn Iterator<Item = usize>| {
        last.fill(u64::MAX);
        for k in order {
            let e = &events[k];
            let (x, y) = (usize::from(e.x), usize::from(e.y));
            'neighbours: for ny in y.saturating_sub(1)..=(y + 1).min(h - 1) {
                for nx in x.saturating_sub(1)..=(x + 1).min(w - 1) {
                    let t = last[ny * w + nx];
                    if (nx, ny) == (x, y) || t == u64::MAX {
                        continue;
                    }
                    if t.abs_diff(e.t_ns) <= NEIGHBOUR_WINDOW_NS {
                        isolated[k] = false;
                        break 'neighbours;
                    }
                }
            }
            last[y * w + x] = e.t_ns;
        }
    };
    pass(&mut (0..events.len()));
    pass(&mut (0..events.len()).rev());
    isolated
}

/// `r` from the isolated rate `r_iso = r·exp(−16·r·τ)`: the root below the curve's maximum
/// (`r < 1/(16τ)`), by bisection; at or past the maximum the maximum's `r`.
fn uncorrect(isolated_hz: f64, tau_s: f64) -> f64 {
    let k = 16.0 * tau_s;
    let peak = 1.0 / k;
    let f = |r: f64| r * (-k * r).exp();
    if isolated_hz >= f(peak) {
        return peak;
    }
    let (mut lo, mut hi) = (0.0, peak);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if f(mid) < isolated_hz {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Indices of the hot pixels: iterate until the set is stable (at most 16 rounds).
fn hot_pixels(total: &[u64]) -> Vec<usize> {
    let mut hot: Vec<usize> = Vec::new();
    for _ in 0..16 {
        let (sum, count) = total
            .iter()
            .enumerate()
            .filter(|(i, _)| hot.binary_search(i).is_err())
            .fold((0u64, 0u64), |(s, c), (_, &t)| (s + t, c + 1));
        let mean = sum as f64 / count.max(1) as f64;
        let next: Vec<usize> = (0..total.len())
            .filter(|&i| total[i] >= HOT_MIN_EVENTS && total[i] as f64 >= HOT_FACTOR * mean)
            .collect();
        if next == hot {
            break;
        }
        hot = next;
    }
    hot
}

/// Lognormal spread (decades) of the rates behind Poisson counts: `σ² = var − mean` of the
/// counts, `σ_log10 = sqrt(ln(1 + σ²/mean²)) / ln 10`.
fn spread_decades(total: &[u64], is_hot: &[bool]) -> f64 {
    let counts: Vec<f64> = total
        .iter()
        .zip(is_hot)
        .filter(|(_, h)| !**h)
        .map(|(&c, _)| c as f64)
        .collect();
    let n = counts.len() as f64;
    if n < 2.0 {
        return 0.0;
    }
    let mean = counts.iter().sum::<f64>() / n;
    let var = counts.iter().map(|c| (c - mean).powi(2)).sum::<f64>() / (n - 1.0);
    let excess = var - mean;
    if mean <= 0.0 || excess <= 0.0 {
        return 0.0;
    }
    (1.0 + excess / (mean * mean)).ln().sqrt() / std::f64::consts::LN_10
}

/// The [`REFRACTORY_QUANTILE`] of the intervals between consecutive events of one pixel.
fn refractory_floor(events: &[Event], n: usize, pixel: impl Fn(&Event) -> usize) -> Option<u64> {
    let mut last = vec![u64::MAX; n];
    let mut intervals = Vec::new();
    for e in events {
        let i = pixel(e);
        if last[i] != u64::MAX {
            intervals.push(e.t_ns - last[i]);
        }
        last[i] = e.t_ns;
    }
    if intervals.len() < MIN_INTERVALS {
        return None;
    }
    let k = ((intervals.len() as f64 * REFRACTORY_QUANTILE) as usize).min(intervals.len() - 1);
    Some(*intervals.select_nth_unstable(k).1)
}

impl SensorFit {
    /// The fitted terms as `--perturb` assignments, sorted by key: shot noise and leak (the
    /// brightness factor, threshold mismatch and leak spread off: a recording without frames
    /// says nothing of them), the hot pixels, the refractory floor when one was measured.
    pub fn terms(&self) -> Vec<(&'static str, f64)> {
        let mut terms = vec![
            ("events.leak_hz", round6(self.leak_hz)),
            ("events.shot_noise_hz", round6(self.shot_noise_hz)),
            ("events.shot_noise_bright_drop", 0.0),
        ];
        if !self.hot_pixels.is_empty() {
            terms.push(("events.hot_pixels", self.hot_pixels.len() as f64));
            terms.push(("events.hot_pixel_hz", round6(self.hot_pixel_hz)));
        }
        if let Some(ns) = self.refractory_floor_ns {
            terms.push(("events.refractory_ms", round6(ns as f64 * 1e-6)));
        }
        terms.sort_by(|a, b| a.0.cmp(b.0));
        terms
    }
}

/// Six significant digits: the figures are measurements, not exact values.
fn round6(v: f64) -> f64 {
    if v == 0.0 || !v.is_finite() {
        return v;
    }
    let scale = 10f64.powi(5 - v.abs().log10().floor() as i32);
    (v * scale).round() / scale
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_isolated_rate_correction_inverts_its_model() {
        let tau = 0.01;
        // Below the curve's maximum (1/(16τ) = 6.25 Hz) the root is unique there.
        for r in [0.01f64, 0.5, 3.0, 6.0] {
            let iso = r * (-16.0 * tau * r).exp();
            assert!((uncorrect(iso, tau) - r).abs() < 1e-9 * r.max(1.0), "{r}");
        }
        // Past it a rate cannot be told from a lower one: the maximum is returned.
        assert_eq!(
            uncorrect(1.0 / (16.0 * tau) * (-1.0f64).exp() + 1.0, tau),
            6.25
        );
    }

    #[test]
    fn bad_input_is_refused_naming_it() {
        let e = |t_ns, x| Event {
            t_ns,
            x,
            y: 0,
            polarity: Polarity::On,
        };
        let static_0_1 = Background::Static {
            start_ns: 0,
            end_ns: 1_000_000_000,
        };
        assert_eq!(
            fit(&[e(5, 0), e(3, 0)], 4, 4, static_0_1),
            Err(FitError::NotInTimeOrder {
                index: 1,
                t_ns: 3,
                previous_ns: 5
            })
        );
        assert!(matches!(
            fit(&[e(5, 9)], 4, 4, static_0_1),
            Err(FitError::OffSensor { index: 0, .. })
        ));
        assert!(matches!(
            fit(&[e(5, 0)], 4, 4, Background::Isolated),
            Err(FitError::NoDuration { .. })
        ));
        assert!(matches!(
            fit(&[], 0, 4, static_0_1),
            Err(FitError::EmptySensor { .. })
        ));
    }
}
