//! The event receiver's ego-motion front end: removes the events the observer's own turning
//! explains, so that what is left is what moved in the world.
//!
//! A hovering drone leans to hold its place, and its rigidly mounted event camera then sees
//! every edge of the static scene move: under the cascade in a light breeze that is ≈ 16 M
//! events in a 97 s link against ≈ 3 M from a still camera, and before the performer first moves
//! it captures the tracker. The airframe's attitude is known (an IMU-aided estimate; see
//! [`proto::stabilise`]), and a rotation of a pinhole camera moves the image of the static scene
//! by a known flow wherever it is. How many events a place of the scene gives for a given flow
//! depends on what is there (its edges and their directions), which the receiver does not know;
//! so it learns it, place by place, in the frame of the camera at its home attitude, where the
//! static scene stays put:
//!
//! * the home image is cut into cells of [`CELL_PX`]; at every turn handed over, each cell
//!   centre's image position under the turn is computed and the path it moved since the previous
//!   one is summed, `F = (ΣΔx, ΣΔy)` over the packet;
//! * each event is mapped to the home frame (the packet's last turn undone) and counted in its
//!   cell, `n`;
//! * per cell and polarity a linear model of the count in the flow split by direction,
//!   `μ = c₀ + a₊·F_x⁺ + a₋·F_x⁻ + b₊·F_y⁺ + b₋·F_y⁻`, is fitted by exponentially
//!   forgetting least squares (time constant [`MEMORY_NS`]; a small ridge keeps it defined while
//!   the flow has kept one direction);
//! * a cell whose count the model explains, `n ≤ (1 + κ)·μ + z·√μ + m`, has its events removed;
//!   a cell above that keeps *all* its events (both edges of a moving object, both polarities);
//! * the model learns from the count clipped to what its prediction explains as a Poisson count
//!   (`(1 + κ)·μ + z·√μ + m`, without the spread the place has shown), so a drone passing
//!   through or coming back to where it rested teaches the place little, while a drone that
//!   comes to rest there is learnt within a few seconds. (Clipped at the bound with the spread,
//!   a place a swaying drone had left kept a bound of ≈ 1 000 events a packet for seconds, and
//!   the drone's return there was removed.)
//!   (A resting drone then gives no events, as it gives none to a still camera.)
//!
//! This is the scene-fixed counterpart of IMU-aided ego-motion compensation for moving-object
//! detection with event cameras (A. Mitrokhin, C. Fermüller, C. Parameshwara and Y. Aloimonos,
//! "Event-based moving object detection and tracking", IROS 2018; D. Falanga, K. Kleber and
//! D. Scaramuzza, "Dynamic obstacle avoidance for quadrotors with event cameras", Science
//! Robotics 5(40), 2020): theirs warp a short window of events by the rotation and threshold a
//! per-pixel timestamp statistic; here the drone moves slowly (a few pixels per packet, as slow
//! as the scene's own swing), so the per-place statistic has to be learnt over seconds instead.
//!
//! Until a turn that moves the image by [`ACTIVATION_PX`] is handed over the front end passes
//! every event and costs nothing: a still camera's receiver computes exactly what it did before
//! this module existed, even when its attitude differs from home in the last bits. While a
//! cell's model is younger than [`WARM_UP_PACKETS`] with flow, its events are removed: it
//! knows nothing yet, and a still camera would not see a resting scene either.

use proto::EventPacket;
use proto::scene::ObserverCamera;
use proto::stabilise::{EgoRotation, predicted_px, stabilised_px};

/// Side of a cell, pixels: about half the performer's image at 1.3–2 m.
pub const CELL_PX: u16 = 16;

/// Image motion, px, of the first turn that switches the front end on.
pub const ACTIVATION_PX: f64 = 0.5;

/// The models' memory, ns: several swings of the airframe (≈ 1 Hz) and shorter than a rest.
pub const MEMORY_NS: u64 = 8_000_000_000;

/// Packets with flow a cell's model must have seen before it keeps anything (≈ 0.5 s: short
/// enough to see a performer's first moves; the young models' leaks are lines, which
/// `MIN_MINOR_SPREAD_PX` drops).
pub const WARM_UP_PACKETS: u32 = 12;

/// The margin of the explained count: relative (`κ`), in standard deviations of a Poisson count
/// (`z`) and absolute (`m`, events).
const KAPPA: f64 = 0.5;
const Z: f64 = 3.0;
const MARGIN_EVENTS: f64 = 3.0;

/// A group of kept cells whose events spread less than this across their principal axis is
/// a line: an under-predicted static edge, not an object (a drone's events spread by its
/// height, several pixels, even edge-on).
const MIN_MINOR_SPREAD_PX: f64 = 1.5;

/// The standard deviation across the principal axis of `total` points with moments `m`
/// (Σx, Σy, Σx², Σy², Σxy), px.
fn minor_spread_px(m: &[f64; 5], total: f64) -> f64 {
    let (mx, my) = (m[0] / total, m[1] / total);
    let (sxx, syy, sxy) = (
        m[2] / total - mx * mx,
        m[3] / total - my * my,
        m[4] / total - mx * my,
    );
    let half_trace = (sxx + syy) / 2.0;
    let root = (((sxx - syy) / 2.0).powi(2) + sxy * sxy).sqrt();
    (half_trace - root).max(0.0).sqrt()
}

/// Packets in a row a cell's neighbourhood must exceed its models before its events are kept.
const PERSIST_PACKETS: u8 = 3;

/// A group of kept cells whose larger polarity has this share of its events is a static edge.
const ONE_SIDED_FRACTION: f64 = 0.9;

/// A cell whose count falls below this share of its prediction has been vacated …
const VACATED_FRACTION: f64 = 0.5;
/// … for this many packets in a row …
const VACATED_PACKETS: u8 = 10;
/// … and its model forgets with this extra factor per such packet (≈ 0.2 s at 25 Hz).
const VACATED_FORGET: f64 = 0.8;

/// The count a model learns from is clipped at this multiple of its Poisson bound.
const LEARN_CLIP: f64 = 1.0;

/// Ridge of the normal equations, in packets' worth of a unit regressor.
const RIDGE: f64 = 0.05;

/// Path below which a packet's flow tells a cell nothing about its gain, px.
const MIN_FLOW_PX: f64 = 0.05;

/// Regressors of a cell's model: a constant and the packet's signed flow split by direction.
const REGRESSORS: usize = 5;

/// `[1, Δx⁺, Δx⁻, Δy⁺, Δy⁻]` of a packet's net flow `f`, px.
fn regressors(f: [f64; 2]) -> [f64; REGRESSORS] {
    [
        1.0,
        f[0].max(0.0),
        (-f[0]).max(0.0),
        f[1].max(0.0),
        (-f[1]).max(0.0),
    ]
}

/// One cell's forgetting least-squares state: one design (the flow) and two counts, ON and
/// OFF events, because a static edge's polarity follows the direction it moves in.
#[derive(Debug, Clone, Copy, Default)]
struct CellModel {
    /// Σ λᵏ x xᵀ.
    xx: [[f64; REGRESSORS]; REGRESSORS],
    /// Σ λᵏ x n, per polarity (0 OFF, 1 ON).
    xn: [[f64; REGRESSORS]; 2],
    /// Packets with flow seen.
    packets: u32,
    /// The current fits, per polarity.
    theta: [[f64; REGRESSORS]; 2],
    /// Forgetting sums of the squared residual of the (clipped) counts, events², per
    /// polarity, and of the weights (so the mean is unbiased from the first packet on).
    residual_sq: [f64; 2],
    weight: f64,
    /// Packets in a row far below the prediction.
    quiet: u8,
}

impl CellModel {
    fn predict(&self, x: &[f64; REGRESSORS], polarity: usize) -> f64 {
        let t = &self.theta[polarity];
        t.iter().zip(x).map(|(a, b)| a * b).sum::<f64>().max(0.0)
    }

    /// The largest count of `polarity` this model explains at regressors `x`.
    fn bound(&self, x: &[f64; REGRESSORS], polarity: usize) -> f64 {
        let mu = self.predict(x, polarity);
        let variance = self.residual_sq[polarity] / self.weight.max(1.0);
        (1.0 + KAPPA) * mu + Z * mu.max(variance).sqrt() + MARGIN_EVENTS
    }

    /// The largest count of `polarity` a Poisson count of the prediction at `x` explains, without
    /// the spread the place has shown: what a count teaches the model is clipped here, so that
    /// a drone passing through or arriving teaches it little however unsettled the place was.
    fn count_bound(&self, x: &[f64; REGRESSORS], polarity: usize) -> f64 {
        let mu = self.predict(x, polarity);
        (1.0 + KAPPA) * mu + Z * mu.sqrt() + MARGIN_EVENTS
    }

    fn learn(&mut self, x: &[f64; REGRESSORS], n: [f64; 2], forget: f64) {
        for (p, &count) in n.iter().enumerate() {
            let r = count - self.predict(x, p);
            self.residual_sq[p] = self.residual_sq[p] * forget + r * r;
        }
        self.weight = self.weight * forget + 1.0;
        for i in 0..REGRESSORS {
            for j in 0..REGRESSORS {
                self.xx[i][j] = self.xx[i][j] * forget + x[i] * x[j];
            }
            for (p, &count) in n.iter().enumerate() {
                self.xn[p][i] = self.xn[p][i] * forget + x[i] * count;
            }
        }
        if x[1..].iter().sum::<f64>() >= MIN_FLOW_PX {
            self.packets = self.packets.saturating_add(1);
        }
        let mut a = self.xx;
        for (i, row) in a.iter_mut().enumerate() {
            row[i] += RIDGE;
        }
        if let Some(l) = cholesky(&a) {
            for p in 0..2 {
                self.theta[p] = solve_cholesky(&l, &self.xn[p]);
            }
        }
    }
}

/// The lower Cholesky factor of a symmetric positive definite `a` (`None` if it is not).
fn cholesky(a: &[[f64; REGRESSORS]; REGRESSORS]) -> Option<[[f64; REGRESSORS]; REGRESSORS]> {
    let mut l = [[0.0; REGRESSORS]; REGRESSORS];
    for i in 0..REGRESSORS {
        for j in 0..=i {
            let s: f64 = (0..j).map(|k| l[i][k] * l[j][k]).sum();
            if i == j {
                let d = a[i][i] - s;
                if !(d.is_finite() && d > 0.0) {
                    return None;
                }
                l[i][i] = d.sqrt();
            } else {
                l[i][j] = (a[i][j] - s) / l[j][j];
            }
        }
    }
    Some(l)
}

/// `L·Lᵀ·θ = b`.
fn solve_cholesky(l: &[[f64; REGRESSORS]; REGRESSORS], b: &[f64; REGRESSORS]) -> [f64; REGRESSORS] {
    let mut y = [0.0; REGRESSORS];
    for i in 0..REGRESSORS {
        y[i] = (b[i] - (0..i).map(|k| l[i][k] * y[k]).sum::<f64>()) / l[i][i];
    }
    let mut theta = [0.0; REGRESSORS];
    for i in (0..REGRESSORS).rev() {
        theta[i] = (y[i] - (i + 1..REGRESSORS).map(|k| l[k][i] * theta[k]).sum::<f64>()) / l[i][i];
    }
    theta
}

/// Events seen and removed by the ego-motion front end.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EgoMotionCounts {
    pub seen: u64,
    pub removed: u64,
}

/// The ego-motion front end of one receiver.
#[derive(Debug, Clone)]
pub struct EgoMotionFilter {
    home: Option<ObserverCamera>,
    cols: usize,
    rows: usize,
    /// The latest turn handed over, and whether any was.
    ego: Option<EgoRotation>,
    active: bool,
    /// Image position of each home cell's centre under the latest turn.
    cell_px: Vec<[f64; 2]>,
    /// How far each home cell's image moved since the last packet, px.
    flow: Vec<[f64; 2]>,
    models: Vec<CellModel>,
    /// Per packet: home-from-image offset of each image cell, events per home cell, kept cells.
    offsets: Vec<[f64; 2]>,
    counts: Vec<[u32; 2]>,
    /// Per home cell: Σx, Σy, Σx², Σy², Σxy of its events' sensor pixels (for a group's shape).
    moments: Vec<[f64; 5]>,
    keep_cell: Vec<bool>,
    /// Per home cell: above its bound at this packet, and for how many packets in a row a
    /// cell of its neighbourhood has been.
    excess: Vec<bool>,
    streak: Vec<u8>,
    /// Scratch of the grouping: visited cells, the stack, one group's members.
    group: Vec<bool>,
    stack: Vec<usize>,
    members: Vec<usize>,
    /// Per event of the packet: its home cell (`usize::MAX`: outside the home image).
    event_cell: Vec<usize>,
    last_end_ns: Option<u64>,
    totals: EgoMotionCounts,
}

impl EgoMotionFilter {
    /// A front end for a `width`×`height` sensor whose camera at its home attitude is `home`
    /// (`None`: turns cannot be undone and the front end passes everything).
    pub fn new(home: Option<ObserverCamera>, width: u16, height: u16) -> Self {
        let cell = usize::from(CELL_PX);
        let (cols, rows) = (
            usize::from(width).div_ceil(cell),
            usize::from(height).div_ceil(cell),
        );
        let centres = (0..rows * cols)
            .map(|c| Self::centre(c, cols))
            .collect::<Vec<_>>();
        Self {
            home,
            cols,
            rows,
            ego: None,
            active: false,
            cell_px: centres,
            flow: vec![[0.0; 2]; rows * cols],
            models: vec![CellModel::default(); rows * cols],
            offsets: vec![[0.0; 2]; rows * cols],
            counts: vec![[0; 2]; rows * cols],
            moments: vec![[0.0; 5]; rows * cols],
            keep_cell: vec![true; rows * cols],
            excess: vec![false; rows * cols],
            streak: vec![0; rows * cols],
            group: Vec::new(),
            stack: Vec::new(),
            members: Vec::new(),
            event_cell: Vec::new(),
            last_end_ns: None,
            totals: EgoMotionCounts::default(),
        }
    }

    fn centre(c: usize, cols: usize) -> [f64; 2] {
        let half = f64::from(CELL_PX) / 2.0;
        [
            (c % cols) as f64 * f64::from(CELL_PX) + half - 0.5,
            (c / cols) as f64 * f64::from(CELL_PX) + half - 0.5,
        ]
    }

    /// Whether any turn has been handed over (and the home camera is known): only then does
    /// [`EgoMotionFilter::filter`] remove anything.
    pub fn active(&self) -> bool {
        self.active
    }

    pub fn counts(&self) -> EgoMotionCounts {
        self.totals
    }

    /// The airframe's turn from its home attitude now (at a render, or a packet's end).
    pub fn set_ego_rotation(&mut self, ego: Option<EgoRotation>) {
        let Some(home) = &self.home else { return };
        if !self.active {
            // A turn that moves the image by less than this is none: an airframe held still
            // in still air still differs from its home attitude in the last bits.
            let turned_px = ego.map_or(0.0, |e| e.angle_rad() * proto::scene::focal_px());
            if turned_px < ACTIVATION_PX {
                return;
            }
            self.active = true;
        }
        for (c, (pos, flow)) in self.cell_px.iter_mut().zip(&mut self.flow).enumerate() {
            let centre = Self::centre(c, self.cols);
            if let Some(now) = predicted_px(home, None, ego.as_ref(), centre) {
                flow[0] += now[0] - pos[0];
                flow[1] += now[1] - pos[1];
                *pos = now;
            }
        }
        self.ego = ego;
    }

    /// Writes the events of `packet` that the airframe's own turning does not explain into
    /// `out` (every other field copied), in their order.
    pub fn filter(&mut self, packet: &EventPacket, out: &mut EventPacket) {
        let forget = match self.last_end_ns {
            Some(last) if packet.end_ns > last => {
                (-((packet.end_ns - last) as f64) / MEMORY_NS as f64).exp()
            }
            _ => (-(packet.end_ns.saturating_sub(packet.start_ns) as f64) / MEMORY_NS as f64).exp(),
        };
        self.last_end_ns = Some(packet.end_ns);
        self.map_events(packet);
        self.judge_cells(forget);
        self.write(packet, out);
    }

    /// Each event's home cell, and the events per home cell.
    fn map_events(&mut self, packet: &EventPacket) {
        let (cell, cols, rows) = (f64::from(CELL_PX), self.cols, self.rows);
        for (c, offset) in self.offsets.iter_mut().enumerate() {
            let q = Self::centre(c, cols);
            *offset = match (&self.home, &self.ego) {
                (Some(home), Some(ego)) => stabilised_px(home, ego, q)
                    .map_or([f64::NAN; 2], |h| [h[0] - q[0], h[1] - q[1]]),
                _ => [0.0; 2],
            };
        }
        self.counts.iter_mut().for_each(|n| *n = [0; 2]);
        self.moments.iter_mut().for_each(|m| *m = [0.0; 5]);
        self.event_cell.clear();
        let cell_px = usize::from(CELL_PX);
        for (i, (&x, &y)) in packet.xs.iter().zip(&packet.ys).enumerate() {
            let (ix, iy) = (usize::from(x) / cell_px, usize::from(y) / cell_px);
            let home_cell = if ix < cols && iy < rows {
                let o = self.offsets[iy * cols + ix];
                let (hx, hy) = (f64::from(x) + o[0], f64::from(y) + o[1]);
                if hx >= 0.0 && hy >= 0.0 && hx < cols as f64 * cell && hy < rows as f64 * cell {
                    (hy / cell) as usize * cols + (hx / cell) as usize
                } else {
                    usize::MAX
                }
            } else {
                usize::MAX
            };
            if home_cell != usize::MAX {
                let on = usize::from(packet.on_bits[i / 8] >> (i % 8) & 1);
                self.counts[home_cell][on] += 1;
                let (fx, fy) = (f64::from(x), f64::from(y));
                let m = &mut self.moments[home_cell];
                *m = [
                    m[0] + fx,
                    m[1] + fy,
                    m[2] + fx * fx,
                    m[3] + fy * fy,
                    m[4] + fx * fy,
                ];
            }
            self.event_cell.push(home_cell);
        }
    }

    /// Which cells keep their events; every model learns this packet.
    fn judge_cells(&mut self, forget: f64) {
        for c in 0..self.models.len() {
            let x = regressors(self.flow[c]);
            let model = &mut self.models[c];
            let bound = [model.bound(&x, 0), model.bound(&x, 1)];
            let n = self.counts[c].map(f64::from);
            // A model still warming up knows nothing yet: its place gives nothing, as the
            // scene gives a still camera nothing.
            self.excess[c] =
                model.packets >= WARM_UP_PACKETS && (n[0] > bound[0] || n[1] > bound[1]);
            self.keep_cell[c] = false;
            let teach = [0, 1].map(|p| n[p].min(LEARN_CLIP * model.count_bound(&x, p)));
            // A place something has left (a drone that rested there) gives far fewer events
            // than it did, packet after packet: forget faster, or the drone's return there is
            // taken for the scene. (A resting drone's jitter pauses for a packet or two too.)
            let mu = model.predict(&x, 0) + model.predict(&x, 1);
            model.quiet = if n[0] + n[1] < VACATED_FRACTION * mu - MARGIN_EVENTS {
                model.quiet.saturating_add(1)
            } else {
                0
            };
            let forget = if model.quiet >= VACATED_PACKETS {
                forget * VACATED_FORGET
            } else {
                forget
            };
            model.learn(&x, teach, forget);
            self.flow[c] = [0.0; 2];
        }
        // A moving object keeps firing in or next to a cell for packet after packet; the
        // scene's own edges and a resting drone's jitter exceed their models in bursts of a
        // packet or two at the turns' extremes.
        let (cols, rows) = (self.cols, self.rows);
        for c in 0..self.models.len() {
            let (cx, cy) = (c % cols, c / cols);
            let near = (cy.saturating_sub(1)..=(cy + 1).min(rows - 1)).any(|y| {
                (cx.saturating_sub(1)..=(cx + 1).min(cols - 1)).any(|x| self.excess[y * cols + x])
            });
            self.streak[c] = if near {
                self.streak[c].saturating_add(1)
            } else {
                0
            };
        }
        for c in 0..self.models.len() {
            self.keep_cell[c] |= self.excess[c] && self.streak[c] >= PERSIST_PACKETS;
        }
        self.grow_kept();
        self.drop_one_sided_groups();
    }

    /// Keeps the neighbours of every kept cell too: an object's cells do not all exceed their
    /// models at once (a resting drone's jitter, the slow part of a stroke), and keeping only
    /// some of them would place it off its centre by up to half its size.
    fn grow_kept(&mut self) {
        let (cols, rows) = (self.cols, self.rows);
        self.group.clear();
        self.group.extend_from_slice(&self.keep_cell);
        for c in 0..self.keep_cell.len() {
            if !self.group[c] {
                continue;
            }
            let (cx, cy) = (c % cols, c / cols);
            for y in cy.saturating_sub(1)..=(cy + 1).min(rows - 1) {
                for x in cx.saturating_sub(1)..=(cx + 1).min(cols - 1) {
                    self.keep_cell[y * cols + x] = true;
                }
            }
        }
    }

    /// Drops every group of kept cells (8-connected) whose events are all but one-sided: a
    /// static edge the model under-predicted moves one way and fires one polarity, while a
    /// moving object fires both of its edges.
    fn drop_one_sided_groups(&mut self) {
        let (cols, rows) = (self.cols, self.rows);
        self.group.clear();
        self.group.resize(self.keep_cell.len(), false);
        for seed in 0..self.keep_cell.len() {
            if !self.keep_cell[seed] || self.group[seed] {
                continue;
            }
            self.stack.clear();
            self.members.clear();
            self.stack.push(seed);
            self.group[seed] = true;
            let mut n = [0u32; 2];
            let mut m = [0.0f64; 5];
            while let Some(c) = self.stack.pop() {
                self.members.push(c);
                n[0] += self.counts[c][0];
                n[1] += self.counts[c][1];
                for (a, b) in m.iter_mut().zip(&self.moments[c]) {
                    *a += b;
                }
                let (cx, cy) = (c % cols, c / cols);
                for y in cy.saturating_sub(1)..=(cy + 1).min(rows - 1) {
                    for x in cx.saturating_sub(1)..=(cx + 1).min(cols - 1) {
                        let d = y * cols + x;
                        if self.keep_cell[d] && !self.group[d] {
                            self.group[d] = true;
                            self.stack.push(d);
                        }
                    }
                }
            }
            let total = f64::from(n[0] + n[1]);
            let one_sided = f64::from(n[0].max(n[1])) >= ONE_SIDED_FRACTION * total;
            if total > 0.0 && (one_sided || minor_spread_px(&m, total) < MIN_MINOR_SPREAD_PX) {
                for &c in &self.members {
                    self.keep_cell[c] = false;
                }
            }
        }
    }

    fn write(&mut self, packet: &EventPacket, out: &mut EventPacket) {
        let (cells, keep) = (&self.event_cell, &self.keep_cell);
        let kept = packet.select_into(out, |i| cells[i] == usize::MAX || keep[cells[i]]);
        let n = self.event_cell.len();
        self.totals.seen += n as u64;
        self.totals.removed += (n - kept) as u64;
    }
}
