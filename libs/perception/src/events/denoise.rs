//! The event receiver's noise front end: a spatio-temporal correlation filter.
//!
//! A real DVS pixel fires without any change in the scene: shot noise (background activity),
//! leak events, hot pixels. Such events are *uncorrelated*: nothing else fires near them at
//! about the same time. The edges of a moving target are the opposite: a whole row of
//! neighbouring pixels crosses its threshold within a few milliseconds. The filter keeps an event
//! only when at least [`DenoiseConfig::min_neighbours`] distinct pixels of its
//! `(2r+1)²−1` neighbourhood fired within [`DenoiseConfig::window_ns`] of it.
//!
//! This is the spatio-temporal correlation filter (STCF) of S. Guo and T. Delbruck,
//! "Low Cost and Latency Event Camera Background Activity Denoising", IEEE TPAMI 45(1), 2023,
//! which generalises the background-activity filter of T. Delbruck, "Frame-free dynamic digital
//! vision", Proc. Int. Symp. on Secure-Life Electronics, 2008 (one correlated neighbour) to *k*
//! of them. Two choices differ from the published filters, both measured in
//! `docs/decisions/noise-front-end.md`:
//!
//! * **Two-sided in time inside a packet.** The receiver steps once per 40 ms packet, so every
//!   event of the packet is known before any is judged: a neighbour counts when it fired within
//!   the window *before or after* the event (events of earlier packets count from the past side
//!   only). The first pixel of an edge to cross is then supported by the pixels that cross just
//!   after it, instead of being dropped as a causal filter drops it.
//! * **Hot-pixel suppression by construction.** A pixel's own events never support it, so a
//!   pixel firing alone at any rate — a hot pixel — is removed, without a learned hot-pixel list.
//!
//! Polarity is ignored (an edge fires ON on one side and OFF on the other). The filter is part of
//! the receiver and always on: a receiver does not know its sensor's noise level. Its settings
//! are physical, not fitted to a preset: a noise event survives with probability
//! `P(Poisson(2·W·r·N) ≥ k)` for a background rate r per pixel, window W and N neighbours,
//! while an edge pixel has ≥ 2 neighbours along the edge firing within the same render.
//!
//! Times are microseconds (as real event cameras stamp them). Cost: per event, `2·N·depth`
//! reads of a per-pixel map of recent times (padded by r so no bounds checks), no allocation
//! after the first packet.

use proto::EventPacket;

use crate::events::background::BackgroundEstimate;
use crate::events::error::EventReceiverError;

mod bands;
mod config;
mod escalation;
mod times;

use bands::{Bands, Entry, prefetch};
pub use config::{Adaptive, DenoiseConfig, DenoiseCounts, MAX_DEPTH, MAX_RADIUS_PX};
use escalation::Escalation;
use times::Times;

/// Packets (40 ms each) the background estimate spans: one second.
const BACKGROUND_PACKETS: usize = 25;

/// Age beyond which a stored time is refreshed to [`times::never`]: times are kept as wrapping
/// u32 microseconds, so every stored age must stay below 2³¹ µs (≈ 36 min) to be read right.
const STALE_US: u32 = 1 << 30;
/// How often (stream time) stored times are swept for staleness: an age read between sweeps is
/// at most `STALE_US + SWEEP_US` < 2³¹ µs, so wrapping subtraction gives it exactly.
const SWEEP_US: u32 = 1 << 29;

/// How many events ahead of the one being judged a pass asks for its neighbourhood's cache
/// lines: far enough for the lines to arrive, near enough that they are still there.
const PREFETCH_AHEAD: usize = 16;

/// Which side of an event in time a pass looks at.
#[derive(Debug, Clone, Copy)]
enum Side {
    Past,
    Next,
}

/// The correlation filter's state: recent event times of every pixel.
///
/// The map of times is cut into horizontal bands with halo rows (module `bands`) and each
/// band's events are judged together, so that one band's cells stay in cache through every
/// pass; the events kept are exactly those of the one-map filter
/// (`tests/denoise_equivalence.rs` checks it against that filter, kept there as the reference).
#[derive(Debug, Clone)]
pub struct NoiseFilter {
    config: DenoiseConfig,
    width: u16,
    height: u16,
    /// The map's layout and the packet's events in band order.
    bands: Bands,
    /// Every band's cells with their halo rows, padded by r columns (padding never fires).
    /// Empty until the first packet gives a time to be stale against.
    times: Times,
    /// Stream time of the last staleness sweep and of the last packet, ns (full width: a gap
    /// longer than the wrapping times can tell is seen here).
    swept_ns: u64,
    last_ns: u64,
    /// Map offsets of the neighbours.
    offsets: Vec<isize>,
    /// Per entry of the band being judged: neighbour events within the window.
    support: Vec<u32>,
    /// Per event of the packet being filtered: on the sensor, kept, core.
    on_sensor: Vec<bool>,
    keep: Vec<bool>,
    core: Vec<bool>,
    /// The packet's first event's time, µs (what a cleared later-event time is stale against).
    first_us: u32,
    /// The packet's earliest and latest event times, µs, full width.
    span_us: (u64, u64),
    /// Per band: no core time stored in its part of the map is later than this, µs, full
    /// width (0 after a reset: nothing stored). See [`NoiseFilter::border_band`].
    band_core_us: Vec<u64>,
    background: BackgroundEstimate,
    escalation: Escalation,
    /// The support asked of the last packet.
    support_now: u8,
    counts: DenoiseCounts,
}

impl NoiseFilter {
    pub fn new(config: DenoiseConfig, width: u16, height: u16) -> Result<Self, EventReceiverError> {
        config.validate()?;
        let r = usize::from(config.radius_px);
        let stride = usize::from(width) + 2 * r;
        let ri = r as isize;
        let mut offsets = Vec::with_capacity(config.neighbours());
        for dy in -ri..=ri {
            for dx in -ri..=ri {
                if (dx, dy) != (0, 0) {
                    offsets.push(dy * stride as isize + dx);
                }
            }
        }
        Ok(Self {
            config,
            width,
            height,
            bands: Bands::new(width, height, r),
            times: Times::default(),
            swept_ns: 0,
            last_ns: 0,
            offsets,
            on_sensor: Vec::new(),
            support: Vec::new(),
            keep: Vec::new(),
            core: Vec::new(),
            first_us: 0,
            span_us: (0, 0),
            band_core_us: Vec::new(),
            background: BackgroundEstimate::new(width, height, BACKGROUND_PACKETS),
            escalation: Escalation::new(width, height, BACKGROUND_PACKETS),
            support_now: 0,
            counts: DenoiseCounts::default(),
        })
    }

    pub fn config(&self) -> &DenoiseConfig {
        &self.config
    }

    /// Events seen and removed so far.
    pub fn counts(&self) -> DenoiseCounts {
        self.counts
    }

    /// The support asked of the last packet (0: every event passed).
    pub fn support_now(&self) -> u8 {
        self.support_now
    }

    /// Whether what survived support `once_support` (measured) has raised the support past
    /// what the model asks for (module `escalation`).
    pub fn escalated(&self) -> bool {
        self.escalation.escalated()
    }

    /// The measured background rate, Hz per pixel.
    pub fn background_hz(&mut self) -> f64 {
        self.background.rate_hz()
    }

    /// Writes the events of `packet` that the filter keeps into `out` (every other field
    /// copied), in their order. Events must be in time order within the packet, as every
    /// camera sends them; an event off the sensor is dropped (the receiver's health check
    /// rejects such packets before they get here).
    pub fn filter(&mut self, packet: &EventPacket, out: &mut EventPacket) {
        let n = packet.len();
        self.counts.seen += n as u64;
        self.prepare(packet);
        let period_ns = packet.end_ns.saturating_sub(packet.start_ns);
        self.background.add(
            period_ns,
            (0..n)
                .filter(|&i| self.on_sensor[i])
                .map(|i| (packet.xs[i], packet.ys[i])),
        );
        // The support asked depends on the background and on earlier packets only, so it is
        // known before this packet's events are counted.
        let k = if self.config.min_neighbours == 0 {
            0
        } else {
            let rate_hz = self.background.rate_hz();
            u32::from(self.escalation.support(&self.config, rate_hz, period_ns))
        };
        self.support_now = k as u8;
        self.judge(k);
        let keep = &self.keep;
        self.escalation.observe(
            &self.config,
            k as u8,
            period_ns,
            (0..n)
                .filter(|&i| keep[i])
                .map(|i| (packet.xs[i], packet.ys[i])),
        );
        let kept = packet.select_into(out, |i| keep[i]);
        self.counts.removed += (n - kept) as u64;
    }

    /// The map made (first packet) or swept for stale times (every [`SWEEP_US`] of stream
    /// time); the packet's events sorted into their bands.
    fn prepare(&mut self, packet: &EventPacket) {
        let now_us = (packet.start_ns / 1_000) as u32;
        let stale_ns = u64::from(STALE_US) * 1_000;
        let jumped = packet.start_ns < self.last_ns || packet.start_ns - self.last_ns > stale_ns;
        if self.times.is_empty() || jumped {
            // First packet, time going back (a restarted stream) or a silence longer than any
            // stored time can be aged over: nothing stored is in reach.
            self.times
                .reset(self.bands.cells(), self.bands.band_cells(), now_us);
            self.band_core_us.clear();
            self.band_core_us.resize(self.bands.count(), 0);
            self.background.clear();
            self.escalation.clear();
            self.swept_ns = packet.start_ns;
        } else if packet.start_ns - self.swept_ns >= u64::from(SWEEP_US) * 1_000 {
            self.times.sweep(now_us);
            self.swept_ns = packet.start_ns;
        }
        self.last_ns = packet.start_ns;
        self.first_us = packet.dt_ns.first().map_or(0, |&dt| {
            (packet.start_ns.wrapping_add(u64::from(dt)) / 1_000) as u32
        });
        let (lo, hi) = packet
            .dt_ns
            .iter()
            .fold((u32::MAX, 0), |(lo, hi), &dt| (lo.min(dt), hi.max(dt)));
        let us = |dt: u32| packet.start_ns.saturating_add(u64::from(dt)) / 1_000;
        self.span_us = (us(lo), us(hi));
        let (w, h) = (self.width, self.height);
        self.on_sensor.clear();
        self.on_sensor.extend(
            packet
                .xs
                .iter()
                .zip(&packet.ys)
                .map(|(&x, &y)| x < w && y < h),
        );
        self.bands.sort(packet, &self.on_sensor);
    }

    /// Prefetches the neighbourhood rows of entry `k` of a band in `times`, whose band part
    /// starts at `base` (0 for the band-relative scratch).
    #[inline(always)]
    fn prefetch_entry<T>(&self, times: &[T], k: usize, base: usize) {
        if let Some(e) = self.bands.get(k) {
            let (cell, r) = (e.cell(base), usize::from(self.config.radius_px));
            let stride = self.bands.stride();
            for row in [cell.wrapping_sub(r * stride), cell, cell + r * stride] {
                prefetch(times, row.wrapping_sub(r));
                prefetch(times, row + r);
            }
        }
    }

    fn window_us(&self) -> u32 {
        (self.config.window_ns / 1_000).min(u64::from(STALE_US / 2)) as u32
    }

    /// Decides every event of the packet for support `k`, band by band: each band's support is
    /// counted (both passes, updating the past times) and its own events kept or not; with
    /// borders, a band's border passes follow once the band below it has been counted (its
    /// halo holds that band's core events), while the band's cells are still in cache. Each
    /// band's part of the map sees the same passes in the same order as when every band was
    /// counted before any border pass, so the events kept are the same.
    fn judge(&mut self, k: u32) {
        let n = self.on_sensor.len();
        self.keep.clear();
        if k == 0 {
            self.keep_all();
            return;
        }
        self.keep.resize(n, false);
        self.core.clear();
        self.core.resize(n, false);
        let borders = self.config.border;
        let bands = self.bands.count();
        for b in 0..=bands {
            if b < bands {
                self.mark_band(b, k);
            }
            if borders && b > 0 {
                self.border_band(b - 1);
            }
        }
    }

    /// Support 0 (no background measured: a noiseless sensor) keeps every event on the sensor,
    /// so nothing is counted: only the past times that later packets count are recorded, every
    /// copy in band order as the forward pass records them. Nothing else that counting touches
    /// outlives the packet: the later-event scratch is cleared after each band (cells it does
    /// not touch keep an older unreachable time, as in any packet), and support 0 records no
    /// core time (it runs no border pass). `tests/denoise_equivalence.rs` checks streams that
    /// go quiet and noisy again.
    fn keep_all(&mut self) {
        self.keep.extend_from_slice(&self.on_sensor);
        for b in 0..self.bands.count() {
            let (entries, base) = self.bands.band(b);
            for j in entries {
                let e = self.bands.entry(j);
                let own = &mut self.times.past[e.cell(base)];
                own.copy_within(..MAX_DEPTH - 1, 1);
                own[0] = e.t;
            }
        }
    }

    /// Counts the support of band `b`'s own events (forward: neighbours' latest events, this
    /// packet's earlier ones included, within the window before; backward: their later events
    /// of this packet within the window after), updates the band's past times, and keeps its
    /// own events with support `k` or more (they are also its core events).
    fn mark_band(&mut self, b: usize, k: u32) {
        let (entries, base) = self.bands.band(b);
        let (lo, hi) = (entries.start, entries.end);
        // A halo entry counts nothing (0): its own band counts it.
        // Support per entry of the band, in band order: both passes walk it in sequence.
        self.support.clear();
        for j in lo..hi {
            self.prefetch_entry(&self.times.past, j + PREFETCH_AHEAD, base);
            let e = self.bands.entry(j);
            let support = self.count_and_record(e, base, Side::Past);
            self.support.push(support);
        }
        for j in (lo..hi).rev() {
            self.prefetch_entry(&self.times.next, j.wrapping_sub(PREFETCH_AHEAD), 0);
            let e = self.bands.entry(j);
            let support = self.count_and_record(e, base, Side::Next);
            self.support[j - lo] += support;
        }
        self.clear_next(lo..hi);
        for j in lo..hi {
            let e = self.bands.entry(j);
            if e.own() {
                let kept = self.support[j - lo] >= k;
                self.keep[e.index()] = kept;
                self.core[e.index()] = kept;
            }
        }
    }

    /// Neighbour events of an own event within the window on `side` (at most `depth` per
    /// pixel), then the event recorded on that side of its pixel's copy.
    #[inline(always)]
    fn count_and_record(&mut self, e: Entry, base: usize, side: Side) -> u32 {
        let (t, window) = (e.t, self.window_us());
        let depth = usize::from(self.config.depth);
        // The past times are the band's part of the map; the later ones its scratch.
        let (times, cell) = match side {
            Side::Past => (&mut self.times.past, e.cell(base)),
            Side::Next => (&mut self.times.next, e.cell(0)),
        };
        let mut support = 0u32;
        if e.own() && self.config.radius_px == 1 && depth == MAX_DEPTH {
            // The receiver's setting, as one fixed-size block the compiler vectorises (with the
            // support per band entry below: the whole filter ≈ 10 % faster than the generic
            // loop, `speed_against_the_reference` in tests/denoise_equivalence.rs).
            let v = neighbourhood_3x3(times, cell, self.bands.stride());
            support = match side {
                Side::Past => v
                    .iter()
                    .map(|&p| u32::from(t.wrapping_sub(p) <= window))
                    .sum(),
                Side::Next => v
                    .iter()
                    .map(|&later| u32::from(later.wrapping_sub(t) <= window))
                    .sum(),
            };
        } else if e.own() {
            for &off in &self.offsets {
                let c = &times[cell.wrapping_add_signed(off)];
                support += match side {
                    Side::Past => c[..depth]
                        .iter()
                        .map(|&p| u32::from(t.wrapping_sub(p) <= window))
                        .sum::<u32>(),
                    Side::Next => c[..depth]
                        .iter()
                        .map(|&later| u32::from(later.wrapping_sub(t) <= window))
                        .sum(),
                };
            }
        }
        let own = &mut times[cell];
        own.copy_within(..MAX_DEPTH - 1, 1);
        own[0] = t;
        support
    }

    /// Forgets this packet's later-event times in one band (they belong to the backward passes
    /// only).
    fn clear_next(&mut self, entries: std::ops::Range<usize>) {
        let never = times::never(self.first_us);
        for k in entries {
            let cell = self.bands.entry(k).cell(0);
            self.times.next[cell] = [never; MAX_DEPTH];
        }
    }

    /// Marks as kept every own event of band `b` with a core event among its neighbours
    /// within the window (forward: this and earlier packets; backward: this packet), and
    /// records the band's core events.
    ///
    /// A band with no core event in this packet (own or halo) and no stored core time within
    /// the window of the packet's earliest event has nothing to find or record: it is skipped.
    /// Under background activity alone that is every band the target does not cross, and the
    /// border passes were ≈ 35–40 % of the filter's time (instrumented, 5 Hz per pixel).
    /// Exact: every stored core time is at most `band_core_us[b]` (an upper bound kept in full
    /// width) and every event at least the packet's earliest, so each age the passes would
    /// read exceeds the window; the sweep keeps every stored age below 2³¹ µs, so the wrapping
    /// ages read the same (`tests/denoise_equivalence.rs` fails when the skip is 20 ms loose).
    fn border_band(&mut self, b: usize) {
        let (entries, base) = self.bands.band(b);
        let (lo, hi) = (entries.start, entries.end);
        let has_core = (lo..hi).any(|j| self.core[self.bands.entry(j).index()]);
        if has_core {
            self.band_core_us[b] = self.band_core_us[b].max(self.span_us.1);
        } else if self.span_us.0 > self.band_core_us[b] + u64::from(self.window_us()) {
            return;
        }
        for j in lo..hi {
            self.prefetch_entry(&self.times.core, j + PREFETCH_AHEAD, base);
            self.border_step(self.bands.entry(j), base, Side::Past);
        }
        for j in (lo..hi).rev() {
            self.prefetch_entry(&self.times.next, j.wrapping_sub(PREFETCH_AHEAD), 0);
            self.border_step(self.bands.entry(j), base, Side::Next);
        }
        self.clear_next(lo..hi);
    }

    /// An own event kept if a neighbour's core event on `side` is within the window; a core
    /// event recorded on that side of its pixel's copy.
    #[inline]
    fn border_step(&mut self, e: Entry, base: usize, side: Side) {
        let i = e.index();
        let (t, window) = (e.t, self.window_us());
        if e.own() && !self.keep[i] {
            let near = |off: isize| match side {
                Side::Past => {
                    t.wrapping_sub(self.times.core[e.cell(base).wrapping_add_signed(off)]) <= window
                }
                Side::Next => {
                    self.times.next[e.cell(0).wrapping_add_signed(off)][0].wrapping_sub(t) <= window
                }
            };
            self.keep[i] = self.offsets.iter().any(|&off| near(off));
        }
        if self.core[i] {
            match side {
                Side::Past => self.times.core[e.cell(base)] = t,
                Side::Next => self.times.next[e.cell(0)][0] = t,
            }
        }
    }
}

/// Both stored times of the 8 neighbours of `cell` (radius 1), row by row: the three cells
/// above, the left and right ones, the three below.
#[inline(always)]
fn neighbourhood_3x3(times: &[[u32; MAX_DEPTH]], cell: usize, stride: usize) -> [u32; 16] {
    let mut v = [0u32; 16];
    v[..6].copy_from_slice(times[cell - stride - 1..cell - stride + 2].as_flattened());
    v[6..8].copy_from_slice(&times[cell - 1]);
    v[8..10].copy_from_slice(&times[cell + 1]);
    v[10..].copy_from_slice(times[cell + stride - 1..cell + stride + 2].as_flattened());
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::Polarity;

    fn packet(start_ns: u64, events: &[(u16, u16, u32, Polarity)]) -> EventPacket {
        EventPacket::from_events(0, (start_ns, start_ns + 40_000_000), (16, 16), events)
    }

    fn kept(filter: &mut NoiseFilter, p: &EventPacket) -> Vec<(u16, u16, u32, Polarity)> {
        let mut out = EventPacket::from_events(0, (0, 0), (0, 0), &[]);
        filter.filter(p, &mut out);
        (0..out.len())
            .map(|i| (out.xs[i], out.ys[i], out.dt_ns[i], out.polarity(i)))
            .collect()
    }

    /// The plain STCF: two distinct neighbours within ±5 ms.
    fn filter() -> NoiseFilter {
        let config = DenoiseConfig {
            radius_px: 1,
            window_ns: 5_000_000,
            min_neighbours: 2,
            border: false,
            depth: 1,
            adaptive: None,
        };
        NoiseFilter::new(config, 16, 16).unwrap()
    }

    const ON: Polarity = Polarity::On;
    const OFF: Polarity = Polarity::Off;

    #[test]
    fn an_isolated_event_and_a_lone_fast_pixel_are_removed() {
        let mut f = filter();
        let lone = [(3, 3, 1_000, ON)];
        assert!(kept(&mut f, &packet(0, &lone)).is_empty());
        // A hot pixel: the same pixel every millisecond never supports itself.
        let hot: Vec<_> = (0..30).map(|k| (8, 8, 1_000_000 * k + 1, ON)).collect();
        assert!(kept(&mut f, &packet(40_000_000, &hot)).is_empty());
        assert_eq!(
            f.counts(),
            DenoiseCounts {
                seen: 31,
                removed: 31
            }
        );
    }

    #[test]
    fn an_edge_is_kept_including_its_first_pixel_and_both_polarities() {
        let mut f = filter();
        // A vertical edge: a column fires, top to bottom over 2 ms, ON and OFF mixed.
        let edge: Vec<_> = (2..12u16)
            .map(|y| {
                (
                    5,
                    y,
                    1_000 + 200_000 * u32::from(y),
                    if y % 2 == 0 { ON } else { OFF },
                )
            })
            .collect();
        let got = kept(&mut f, &packet(0, &edge));
        // The two ends have one neighbour on the edge: removed; everything between is kept,
        // the first interior pixel thanks to the later one (two-sided window).
        assert_eq!(got, edge[1..edge.len() - 1].to_vec());
    }

    #[test]
    fn correlation_needs_the_window_and_spans_packets_from_the_past_only() {
        let mut f = filter();
        // Two neighbours 6 ms before: outside ±5 ms.
        let first = [(4, 4, 30_000_000, ON), (6, 4, 30_000_000, ON)];
        kept(&mut f, &packet(0, &first));
        let late = [(5, 4, 36_000_000, ON)];
        assert!(kept(&mut f, &packet(0, &late)).is_empty());
        // In the next packet, 4 ms after the previous packet's pair: kept.
        let mut g = filter();
        kept(&mut g, &packet(0, &first));
        let next = [(5, 4, 0, OFF)];
        assert_eq!(
            kept(&mut g, &packet(34_000_000, &next)),
            vec![(5, 4, 0, OFF)]
        );
    }

    #[test]
    fn depth_two_counts_a_neighbour_that_fired_twice_and_borders_join_their_core() {
        let config = DenoiseConfig {
            radius_px: 1,
            window_ns: 5_000_000,
            min_neighbours: 3,
            border: false,
            depth: 2,
            adaptive: None,
        };
        // (5,5) has two neighbours: (4,5) fired twice, (6,5) once: support 3.
        let events = [
            (4, 5, 1_000, ON),
            (4, 5, 2_000, ON),
            (5, 5, 3_000, OFF),
            (6, 5, 4_000, OFF),
        ];
        let mut f = NoiseFilter::new(config, 16, 16).unwrap();
        assert_eq!(kept(&mut f, &packet(0, &events)), vec![(5, 5, 3_000, OFF)]);
        // With borders, the core event's neighbours within the window are kept too; a pixel
        // two away is not.
        let mut g = NoiseFilter::new(
            DenoiseConfig {
                border: true,
                ..config
            },
            16,
            16,
        )
        .unwrap();
        let with_far = [events.to_vec(), vec![(8, 5, 4_500, ON)]].concat();
        assert_eq!(kept(&mut g, &packet(0, &with_far)), events.to_vec());
    }

    #[test]
    fn the_adaptive_support_grows_with_the_background_and_is_zero_without_one() {
        let c = DenoiseConfig::receiver();
        let packet_ns = 40_000_000;
        assert_eq!(c.support_for(0.0, packet_ns), 0);
        assert_eq!(c.support_for(3.0, packet_ns), 8);
        assert_eq!(
            c.support_for(5.0, packet_ns),
            8,
            "8 leaves ≈ 0.09 noise events"
        );
        assert_eq!(c.support_for(6.5, packet_ns), 8);
        assert_eq!(
            c.support_for(7.0, packet_ns),
            11,
            "8 would leave more than one"
        );
        assert_eq!(c.support_for(10.0, packet_ns), 13);
        assert_eq!(
            c.support_for(1e4, packet_ns),
            16,
            "capped at min_neighbours"
        );
        let mut last = 0;
        for k in 0..=60 {
            let rate_hz = 1e-4 * 1.2f64.powi(k);
            let support = c.support_for(rate_hz, packet_ns);
            assert!(support >= last, "{rate_hz} Hz: {support} after {last}");
            last = support;
        }
        // Without adaptation the support is fixed.
        let fixed = DenoiseConfig {
            adaptive: None,
            ..c
        };
        assert_eq!(fixed.support_for(0.0, packet_ns), 16);
    }

    #[test]
    fn a_noiseless_stream_passes_untouched() {
        let mut f = NoiseFilter::new(DenoiseConfig::receiver(), 640, 480).unwrap();
        // A hot pixel: with nothing else firing on the sensor, the median cell's background is
        // zero, so nothing is asked of it.
        let events: Vec<_> = (0..30).map(|k| (8, 8, 1_000_000 * k + 1, ON)).collect();
        assert_eq!(kept(&mut f, &packet(0, &events)), events);
        assert_eq!(f.support_now(), 0);
    }

    #[test]
    fn off_keeps_everything_and_bad_settings_are_refused() {
        let mut f = NoiseFilter::new(DenoiseConfig::off(), 16, 16).unwrap();
        let events = [(1, 1, 5, ON), (14, 14, 9, OFF)];
        assert_eq!(kept(&mut f, &packet(0, &events)), events.to_vec());
        for bad in [
            DenoiseConfig {
                radius_px: 0,
                ..DenoiseConfig::receiver()
            },
            DenoiseConfig {
                radius_px: 3,
                ..DenoiseConfig::receiver()
            },
            DenoiseConfig {
                min_neighbours: 25,
                ..DenoiseConfig::receiver()
            },
            DenoiseConfig {
                depth: 3,
                ..DenoiseConfig::receiver()
            },
        ] {
            assert!(NoiseFilter::new(bad, 16, 16).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn stored_times_never_alias_across_long_gaps_or_restarts() {
        let pair = [(4, 4, 1_000, ON), (6, 4, 1_000, ON)];
        let probe = [(5, 4, 1_000, OFF)];
        // 2³² µs later the wrapping times would read as simultaneous.
        let wrap_ns = (1u64 << 32) * 1_000;
        for (gap_ns, steps) in [(wrap_ns, 1u64), (wrap_ns, 4_000), (1u64 << 40, 1)] {
            let mut f = filter();
            kept(&mut f, &packet(0, &pair));
            // Intermediate packets (empty) every gap/steps, as a live camera sends them.
            for k in 1..steps {
                kept(&mut f, &packet(k * (gap_ns / steps), &[]));
            }
            assert!(
                kept(&mut f, &packet(gap_ns, &probe)).is_empty(),
                "gap {gap_ns} / {steps}"
            );
        }
        // Time going back (a restarted stream) forgets everything.
        let mut f = filter();
        kept(&mut f, &packet(500_000_000, &pair));
        assert!(kept(&mut f, &packet(0, &probe)).is_empty());
    }

    #[test]
    fn events_off_the_sensor_are_dropped_not_a_panic() {
        let mut f = filter();
        let events = [
            (15, 15, 1, ON),
            (16, 3, 2, ON),
            (u16::MAX, u16::MAX, 3, OFF),
        ];
        assert!(kept(&mut f, &packet(0, &events)).is_empty());
    }
}
