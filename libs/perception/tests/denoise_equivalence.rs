//! The noise front end against its former, one-map implementation (kept here verbatim as the
//! reference): the banded filter must keep exactly the same events of every packet, on streams
//! generated with every setting the filter accepts — noise, edges, hot pixels, events off the
//! sensor, out-of-order events, long silences and restarts, packets of any length.

#[path = "support/rng.rs"]
mod rng;
use perception::events::{BackgroundEstimate, DenoiseConfig, DenoiseCounts, NoiseFilter};
use proto::{EventPacket, Polarity};
use rng::Rng;

/// Packets (40 ms each) the background estimate spans: one second.
const BACKGROUND_PACKETS: usize = 25;
/// Most events remembered per pixel.
const MAX_DEPTH: usize = 2;

/// Age beyond which a stored time is refreshed to [`Cell::stale`]: times are kept as wrapping
/// u32 microseconds, so every stored age must stay below 2³¹ µs (≈ 36 min) to be read right.
const STALE_US: u32 = 1 << 30;
/// How often (stream time) stored times are swept for staleness: an age read between sweeps is
/// at most `STALE_US + SWEEP_US` < 2³¹ µs, so wrapping subtraction gives it exactly.
const SWEEP_US: u32 = 1 << 29;

/// One pixel's times, microseconds (wrapping u32; see [`STALE_US`]). Kept together so a
/// neighbourhood lookup touches three short runs of memory, not five maps.
#[derive(Debug, Clone, Copy)]
struct Cell {
    /// The pixel's latest and second-latest events so far.
    past: [u32; MAX_DEPTH],
    /// Inside one packet's backward pass: its earliest and second-earliest later events.
    next: [u32; MAX_DEPTH],
    /// Its latest core event so far (with borders).
    core: u32,
}

impl Cell {
    /// A cell with nothing in reach of a time `now_us`.
    fn stale(now_us: u32) -> Self {
        let never = now_us.wrapping_sub(STALE_US);
        Self {
            past: [never; MAX_DEPTH],
            next: [never; MAX_DEPTH],
            core: never,
        }
    }
}

/// Which side of an event in time a pass looks at.
#[derive(Debug, Clone, Copy)]
enum Side {
    Past,
    Next,
}

/// The correlation filter's state: recent event times of every pixel.
#[derive(Debug, Clone)]
pub struct ReferenceFilter {
    config: DenoiseConfig,
    width: u16,
    height: u16,
    /// Row stride of the padded map (`width + 2r`).
    stride: usize,
    /// Every pixel's times, padded by r on every side (the border never fires). Empty until the
    /// first packet gives a time to be stale against.
    map: Vec<Cell>,
    /// Stream time of the last staleness sweep and of the last packet, ns (full width: a gap
    /// longer than the wrapping times can tell is seen here).
    swept_ns: u64,
    last_ns: u64,
    /// Padded-map offsets of the neighbours.
    offsets: Vec<isize>,
    /// Per event of the packet being filtered: its time (µs), padded cell (`usize::MAX`: off
    /// the sensor), neighbour events within the window, kept.
    times: Vec<u32>,
    cells: Vec<usize>,
    support: Vec<u32>,
    keep: Vec<bool>,
    core: Vec<bool>,
    background: BackgroundEstimate,
    /// Events kept at the adaptive `once_support` over the last second at it, and whether
    /// their median cell has ever exceeded the tolerance (the support then follows the budget).
    survivors: BackgroundEstimate,
    escalated: bool,
    /// The support asked of the last packet.
    support_now: u8,
    counts: DenoiseCounts,
}

impl ReferenceFilter {
    pub fn new(config: DenoiseConfig, width: u16, height: u16) -> Self {
        config.validate().expect("valid settings");
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
        Self {
            config,
            width,
            height,
            stride,
            map: Vec::new(),
            swept_ns: 0,
            last_ns: 0,
            offsets,
            times: Vec::new(),
            cells: Vec::new(),
            support: Vec::new(),
            keep: Vec::new(),
            core: Vec::new(),
            background: BackgroundEstimate::new(width, height, BACKGROUND_PACKETS),
            survivors: BackgroundEstimate::new(width, height, BACKGROUND_PACKETS),
            escalated: false,
            support_now: 0,
            counts: DenoiseCounts::default(),
        }
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
        self.mark();
        let period_ns = packet.end_ns.saturating_sub(packet.start_ns);
        self.background.add(
            period_ns,
            (0..n)
                .filter(|&i| self.cells[i] != usize::MAX)
                .map(|i| (packet.xs[i], packet.ys[i])),
        );
        let k = if self.config.min_neighbours == 0 {
            0
        } else {
            let rate_hz = self.background.rate_hz();
            let modelled = self.config.support_for(rate_hz, period_ns);
            let once = self.config.adaptive.map(|a| a.once_support);
            if once.is_some_and(|once| modelled < once) {
                self.escalated = false;
            }
            u32::from(if self.escalated {
                self.config.budget_support(rate_hz, period_ns)
            } else {
                modelled
            })
        };
        self.support_now = k as u8;
        self.keep.clear();
        self.keep.extend(
            self.cells
                .iter()
                .zip(&self.support)
                .map(|(&cell, &support)| cell != usize::MAX && support >= k),
        );
        if self.config.border && k > 0 {
            self.grow_borders();
        }
        self.measure_survivors(packet, k, period_ns);
        let keep = &self.keep;
        let kept = packet.select_into(out, |i| keep[i]);
        self.counts.removed += (n - kept) as u64;
    }

    fn measure_survivors(&mut self, packet: &EventPacket, k: u32, period_ns: u64) {
        let Some(a) = self.config.adaptive else {
            return;
        };
        if self.escalated || k != u32::from(a.once_support) {
            self.survivors.clear();
            return;
        }
        let keep = &self.keep;
        self.survivors.add(
            period_ns,
            (0..packet.len())
                .filter(|&i| keep[i])
                .map(|i| (packet.xs[i], packet.ys[i])),
        );
        let per_window =
            self.survivors.rate_hz() * f64::from(a.window_px) * period_ns as f64 * 1e-9;
        if self.survivors.packets() >= BACKGROUND_PACKETS && per_window > a.tolerated_events {
            self.escalated = true;
            self.survivors.clear();
        }
    }

    /// The packet's event times and cells; the map made (first packet) or swept for stale
    /// times (every [`SWEEP_US`] of stream time).
    fn prepare(&mut self, packet: &EventPacket) {
        let now_us = (packet.start_ns / 1_000) as u32;
        let r = usize::from(self.config.radius_px);
        let stale_ns = u64::from(STALE_US) * 1_000;
        let jumped = packet.start_ns < self.last_ns || packet.start_ns - self.last_ns > stale_ns;
        if self.map.is_empty() || jumped {
            // First packet, time going back (a restarted stream) or a silence longer than any
            // stored time can be aged over: nothing stored is in reach.
            let rows = usize::from(self.height) + 2 * r;
            self.map.clear();
            self.map.resize(self.stride * rows, Cell::stale(now_us));
            self.background.clear();
            self.survivors.clear();
            self.escalated = false;
            self.swept_ns = packet.start_ns;
        } else if packet.start_ns - self.swept_ns >= u64::from(SWEEP_US) * 1_000 {
            for cell in &mut self.map {
                for t in cell.past.iter_mut().chain(cell.next.iter_mut()) {
                    if now_us.wrapping_sub(*t) > STALE_US {
                        *t = now_us.wrapping_sub(STALE_US);
                    }
                }
                if now_us.wrapping_sub(cell.core) > STALE_US {
                    cell.core = now_us.wrapping_sub(STALE_US);
                }
            }
            self.swept_ns = packet.start_ns;
        }
        self.last_ns = packet.start_ns;
        self.times.clear();
        self.times.extend(
            packet
                .dt_ns
                .iter()
                .map(|&dt| (packet.start_ns.wrapping_add(u64::from(dt)) / 1_000) as u32),
        );
        self.cells.clear();
        self.cells
            .extend(packet.xs.iter().zip(&packet.ys).map(|(&x, &y)| {
                if x < self.width && y < self.height {
                    (usize::from(y) + r) * self.stride + usize::from(x) + r
                } else {
                    usize::MAX
                }
            }));
    }

    fn window_us(&self) -> u32 {
        (self.config.window_ns / 1_000).min(u64::from(STALE_US / 2)) as u32
    }

    /// Counts every event's support (both passes) and updates the past times.
    fn mark(&mut self) {
        let n = self.cells.len();
        self.support.clear();
        self.support.resize(n, 0);
        // Forward: neighbours' latest events (this packet's earlier ones included) within the
        // window before; then backward: their later events of this packet within the window
        // after.
        for i in 0..n {
            self.support[i] = self.count_and_record(i, Side::Past);
        }
        for i in (0..n).rev() {
            self.support[i] += self.count_and_record(i, Side::Next);
        }
        self.clear_next();
    }

    /// Neighbour events of event `i` within the window on `side` (at most `depth` per pixel),
    /// then `i` recorded on that side of its own pixel.
    fn count_and_record(&mut self, i: usize, side: Side) -> u32 {
        let cell = self.cells[i];
        if cell == usize::MAX {
            return 0;
        }
        let (t, window) = (self.times[i], self.window_us());
        let depth = usize::from(self.config.depth);
        let mut support = 0u32;
        for &off in &self.offsets {
            let c = &self.map[cell.wrapping_add_signed(off)];
            support += match side {
                Side::Past => c.past[..depth]
                    .iter()
                    .map(|&p| u32::from(t.wrapping_sub(p) <= window))
                    .sum::<u32>(),
                Side::Next => c.next[..depth]
                    .iter()
                    .map(|&later| u32::from(later.wrapping_sub(t) <= window))
                    .sum(),
            };
        }
        let times = match side {
            Side::Past => &mut self.map[cell].past,
            Side::Next => &mut self.map[cell].next,
        };
        times.copy_within(..MAX_DEPTH - 1, 1);
        times[0] = t;
        support
    }

    /// Forgets this packet's later-event times (they belong to the backward passes only).
    fn clear_next(&mut self) {
        let never = self.times.first().map_or(0, |&t| t.wrapping_sub(STALE_US));
        for &cell in &self.cells {
            if cell != usize::MAX {
                self.map[cell].next = [never; MAX_DEPTH];
            }
        }
    }

    /// Marks as kept every event with a core event among its neighbours within the window
    /// (forward: this and earlier packets; backward: this packet), and records this packet's
    /// core events.
    fn grow_borders(&mut self) {
        self.core.clear();
        self.core.extend_from_slice(&self.keep);
        for i in 0..self.cells.len() {
            self.border_step(i, Side::Past);
        }
        for i in (0..self.cells.len()).rev() {
            self.border_step(i, Side::Next);
        }
        self.clear_next();
    }

    /// Event `i` kept if a neighbour's core event on `side` is within the window; a core event
    /// recorded on that side of its own pixel.
    fn border_step(&mut self, i: usize, side: Side) {
        let cell = self.cells[i];
        if cell == usize::MAX {
            return;
        }
        let (t, window) = (self.times[i], self.window_us());
        let core_time = |c: &Cell| match side {
            Side::Past => t.wrapping_sub(c.core),
            Side::Next => c.next[0].wrapping_sub(t),
        };
        if !self.keep[i] {
            self.keep[i] = self
                .offsets
                .iter()
                .any(|&off| core_time(&self.map[cell.wrapping_add_signed(off)]) <= window);
        }
        if self.core[i] {
            match side {
                Side::Past => self.map[cell].core = t,
                Side::Next => self.map[cell].next[0] = t,
            }
        }
    }
}

/// Any setting the filter accepts.
fn config(rng: &mut Rng) -> DenoiseConfig {
    if rng.chance(0.2) {
        return DenoiseConfig::receiver();
    }
    let radius_px = 1 + rng.below(2) as u16;
    let depth = 1 + rng.below(2) as u8;
    let side = 2 * u64::from(radius_px) + 1;
    let most = u64::from(depth) * (side * side - 1);
    let window_ns = match rng.below(4) {
        0 => rng.below(1_000_000),
        1 => rng.below(50_000_000),
        2 => 15_000_000,
        _ => rng.below(1 << 42),
    };
    DenoiseConfig {
        radius_px,
        window_ns,
        min_neighbours: rng.below(most + 1) as u8,
        border: rng.chance(0.6),
        depth,
        adaptive: rng.chance(0.4).then(|| perception::events::Adaptive {
            budget_events: [0.001, 0.01, 1.0, 100.0][rng.below(4) as usize],
            window_px: 1 + rng.below(20_000) as u32,
            once_support: rng.below(most + 1) as u8,
            tolerated_events: [0.01, 1.0, 100.0][rng.below(3) as usize],
        }),
    }
}

/// One packet's events: background, edges sweeping across, a hot pixel, dense patches, events
/// off the sensor; in time order, or shuffled now and then (the filter must not care how).
/// A `quiet` packet has no background and no hot pixel (a noiseless sensor: support 0).
fn events(
    rng: &mut Rng,
    (w, h): (u16, u16),
    period_ns: u64,
    quiet: bool,
) -> Vec<(u16, u16, u32, Polarity)> {
    let span = u32::try_from(period_ns.max(1)).unwrap_or(u32::MAX);
    let mut out = Vec::new();
    let polarity = |rng: &mut Rng| {
        if rng.chance(0.5) {
            Polarity::On
        } else {
            Polarity::Off
        }
    };
    let noise = if quiet {
        0
    } else {
        rng.below(4 * u64::from(w) * u64::from(h) / 10 + 1)
    };
    for _ in 0..noise {
        let (x, y) = (
            rng.below(u64::from(w)) as u16,
            rng.below(u64::from(h)) as u16,
        );
        out.push((x, y, rng.below(u64::from(span)) as u32, polarity(rng)));
    }
    for _ in 0..rng.below(3) {
        // An edge: a row or a column firing within a few ms, some pixels twice.
        let vertical = rng.chance(0.5);
        let at = rng.below(u64::from(if vertical { w } else { h }));
        let t0 = rng.below(u64::from(span));
        for k in 0..u64::from(if vertical { h } else { w }) {
            let (x, y) = if vertical { (at, k) } else { (k, at) };
            for _ in 0..1 + rng.below(2) {
                let t = (t0 + k * 30_000 + rng.below(2_000_000)).min(u64::from(span));
                out.push((x as u16, y as u16, t as u32, polarity(rng)));
            }
        }
    }
    if !quiet && rng.chance(0.3) {
        let (x, y) = (
            rng.below(u64::from(w)) as u16,
            rng.below(u64::from(h)) as u16,
        );
        for k in 0..rng.below(40) {
            out.push((
                x,
                y,
                (k * 1_000_000).min(u64::from(span)) as u32,
                Polarity::On,
            ));
        }
    }
    for _ in 0..rng.below(3) {
        // A dense patch (a blob's edge): every pixel of a few-pixel square, some several times.
        let (x0, y0) = (rng.below(u64::from(w)), rng.below(u64::from(h)));
        let t0 = rng.below(u64::from(span));
        for dy in 0..1 + rng.below(6) {
            for dx in 0..1 + rng.below(6) {
                let (x, y) = (
                    (x0 + dx).min(u64::from(w) - 1),
                    (y0 + dy).min(u64::from(h) - 1),
                );
                let t = (t0 + rng.below(8_000_000)).min(u64::from(span)) as u32;
                out.push((x as u16, y as u16, t, polarity(rng)));
            }
        }
    }
    for _ in 0..rng.below(3) {
        let (x, y) = if rng.chance(0.5) {
            (w + rng.below(5) as u16, rng.below(u64::from(h)) as u16)
        } else {
            (u16::MAX, u16::MAX)
        };
        out.push((x, y, rng.below(u64::from(span)) as u32, Polarity::On));
    }
    if rng.chance(0.9) {
        out.sort_by_key(|e| e.2);
    } else if rng.chance(0.5) {
        // Beyond the packet's end (a malformed camera): the filter must still agree.
        for e in out.iter_mut().take(5) {
            e.2 = e.2.saturating_add(rng.below(1 << 31) as u32);
        }
    }
    out
}

/// Packet start times: regular, with gaps, wrap-sized silences and restarts.
fn next_start(rng: &mut Rng, start_ns: u64, period_ns: u64) -> u64 {
    match rng.below(40) {
        0 => start_ns + (1u64 << 32) * 1_000 + rng.below(1 << 40),
        1 => start_ns / 2,
        2 => start_ns + (1u64 << 29) * 1_000,
        3 => start_ns + rng.below(10 * period_ns),
        _ => start_ns + period_ns,
    }
}

/// Checks the filter against the reference on one seeded stream; returns how many packets were
/// judged at support 0 right after one at a higher support, and the reverse (the quiet
/// patterns' coverage).
fn same_output(seed: u64, size: (u16, u16), packets: usize) -> (u32, u32) {
    let mut rng = Rng(seed);
    let config = config(&mut rng);
    let mut fast = NoiseFilter::new(config, size.0, size.1).expect("valid settings");
    let mut slow = ReferenceFilter::new(config, size.0, size.1);
    let (mut a, mut b) = (
        EventPacket::from_events(0, (0, 0), size, &[]),
        EventPacket::from_events(0, (0, 0), size, &[]),
    );
    let period_ns =
        [1_000_000, 10_000_000, 40_000_000, 40_000_000, 100_000_000][rng.below(5) as usize];
    let mut start_ns = rng.below(1 << 45);
    // Noisy throughout, quiet for the first half (support 0, then rising), or quiet and noisy
    // in turns of three packets (support falling back to 0 and rising again).
    let pattern = rng.below(3);
    let (mut transitions, mut last_support) = ((0, 0), 0);
    for k in 0..packets {
        let quiet = match pattern {
            0 => false,
            1 => k < packets / 2,
            _ => (k / 3) % 2 == 0,
        };
        let events = events(&mut rng, size, period_ns, quiet);
        let packet =
            EventPacket::from_events(k as u64, (start_ns, start_ns + period_ns), size, &events);
        fast.filter(&packet, &mut a);
        slow.filter(&packet, &mut b);
        let kept = |p: &EventPacket| -> Vec<_> {
            (0..p.len())
                .map(|i| (p.xs[i], p.ys[i], p.dt_ns[i], p.polarity(i)))
                .collect()
        };
        let (got, want) = (kept(&a), kept(&b));
        if got != want {
            let first = got.iter().zip(&want).position(|(g, w)| g != w);
            panic!(
                "seed {seed}, {size:?}, packet {k} of {} events, {config:?}: kept {} vs {}, first \
                 difference at {first:?}: {:?} vs {:?}",
                packet.len(),
                got.len(),
                want.len(),
                first.map(|i| got[i]),
                first.map(|i| want[i])
            );
        }
        assert_eq!(
            fast.support_now(),
            slow.support_now(),
            "seed {seed}, packet {k}"
        );
        assert_eq!(fast.counts(), slow.counts(), "seed {seed}, packet {k}");
        let support = fast.support_now();
        if k > 0 && (support == 0) != (last_support == 0) {
            if support == 0 {
                transitions.0 += 1;
            } else {
                transitions.1 += 1;
            }
        }
        last_support = support;
        start_ns = next_start(&mut rng, start_ns, period_ns);
    }
    transitions
}

#[test]
fn the_filter_keeps_exactly_what_the_reference_keeps_on_small_sensors() {
    let (mut to_zero, mut from_zero) = (0, 0);
    for seed in 0..400 {
        let mut rng = Rng(seed ^ 0xA5A5);
        let size = (1 + rng.below(48) as u16, 1 + rng.below(90) as u16);
        let (down, up) = same_output(seed, size, 12);
        (to_zero, from_zero) = (to_zero + down, from_zero + up);
    }
    // Support 0 keeps everything without counting: the streams must go in and out of it.
    println!("support fell to 0 {to_zero} times and rose from it {from_zero} times");
    assert!(
        to_zero >= 10 && from_zero >= 10,
        "{to_zero} falls to support 0, {from_zero} rises from it"
    );
}

#[test]
fn the_filter_keeps_exactly_what_the_reference_keeps_on_the_paper_sensor() {
    for seed in 1_000..1_006 {
        same_output(seed, (640, 480), 6);
    }
}

/// CPU time of this thread, ns (Linux's scheduler statistics), so that time spent waiting for
/// a core that others hold is not counted; wall time elsewhere.
fn cpu_ns() -> u64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse().ok())
        .unwrap_or_else(|| {
            static START: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();
            START
                .get_or_init(std::time::Instant::now)
                .elapsed()
                .as_nanos() as u64
        })
}

/// The speed of the banded filter against the reference on 5 Hz background activity (one
/// core, interleaved repetitions, the median of each): run with `--ignored --nocapture`.
#[test]
#[ignore = "a measurement, not a check: run with --ignored --nocapture"]
fn speed_against_the_reference() {
    let (w, h, period_ns) = (640u16, 480u16, 40_000_000u64);
    let mut rng = Rng(5);
    let packets: Vec<EventPacket> = (0..50u64)
        .map(|k| {
            let n = 5.0 * f64::from(w) * f64::from(h) * 0.04;
            let mut events: Vec<_> = (0..n as u64)
                .map(|_| {
                    let (x, y) = (
                        rng.below(u64::from(w)) as u16,
                        rng.below(u64::from(h)) as u16,
                    );
                    (x, y, 1 + rng.below(period_ns - 1) as u32, Polarity::On)
                })
                .collect();
            events.sort_by_key(|e| (e.2, e.1, e.0));
            EventPacket::from_events(k, (k * period_ns, (k + 1) * period_ns), (w, h), &events)
        })
        .collect();
    let events: usize = packets.iter().map(EventPacket::len).sum();
    let mut out = EventPacket::from_events(0, (0, 0), (w, h), &[]);
    let (mut fast, mut slow) = (Vec::new(), Vec::new());
    for _ in 0..5 {
        let mut f = NoiseFilter::new(DenoiseConfig::receiver(), w, h).expect("valid");
        let start = cpu_ns();
        for p in &packets {
            f.filter(p, &mut out);
        }
        fast.push((cpu_ns() - start) as f64 * 1e-9);
        let mut f = ReferenceFilter::new(DenoiseConfig::receiver(), w, h);
        let start = cpu_ns();
        for p in &packets {
            f.filter(p, &mut out);
        }
        slow.push((cpu_ns() - start) as f64 * 1e-9);
    }
    fast.sort_by(f64::total_cmp);
    slow.sort_by(f64::total_cmp);
    let (fast, slow) = (fast[2], slow[2]);
    println!(
        "{events} events: banded {:.1} M events/s, reference {:.1} M events/s, ratio {:.2}",
        events as f64 / fast / 1e6,
        events as f64 / slow / 1e6,
        slow / fast
    );
}
