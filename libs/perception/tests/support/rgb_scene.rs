//! Synthetic RGB frames for the RGB receiver tests: a textured dark-and-light "drone" of the
//! real one's size (48 × 12 px) on a blue-grey wall, drawn with exact area coverage so that a
//! sub-pixel move of the drone is a true sub-pixel shift of the image, and flight plans that
//! move it along each action's keypoint path at 25 Hz with NULL rests in between.

#![allow(dead_code)]

use proto::{Action, RgbFrame};

pub const WIDTH: u16 = 640;
pub const HEIGHT: u16 = 480;
pub const PERIOD_NS: u64 = 40_000_000;
/// Hover point of the performer in the image (pixel-centre coordinates).
pub const HOVER_PX: [f64; 2] = [319.5, 239.5];
/// Image amplitude of START / END and of the bits' depth (0.15 m at 1.26 m ≈ 69 px).
pub const AMPLITUDE_PX: f64 = 69.0;
/// Image width of a bit's V.
pub const BIT_WIDTH_PX: f64 = 80.0;
/// NULL rest between symbols.
pub const REST_NS: u64 = 4_500_000_000;

const WALL: [u8; 3] = [110, 128, 150];
const WALL_SHADE: [u8; 3] = [95, 112, 132];
const FLOOR: [u8; 3] = [72, 72, 76];

/// Disjoint rectangles of the drone, relative to its centre: `[x0, x1, y0, y1, grey]`.
const DRONE: [[f64; 5]; 10] = [
    [-24.0, -14.0, -6.0, -4.5, 235.0], // left rotor guard
    [14.0, 24.0, -6.0, -4.5, 235.0],   // right rotor guard
    [-21.0, -17.0, -4.5, 2.0, 25.0],   // left motor pod
    [17.0, 21.0, -4.5, 2.0, 25.0],     // right motor pod
    [-17.0, -6.0, -1.0, 1.0, 40.0],    // left arm
    [6.0, 17.0, -1.0, 1.0, 40.0],      // right arm
    [-6.0, 6.0, -3.0, 1.0, 200.0],     // silver body
    [-4.0, 4.0, 1.0, 4.0, 30.0],       // battery
    [-20.0, -18.0, 2.0, 6.0, 240.0],   // left leg
    [18.0, 20.0, 2.0, 6.0, 240.0],     // right leg
];

/// Background of a frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Backdrop {
    /// Uniform blue-grey wall.
    Wall,
    /// Like our MuJoCo view of O1: a wall corner (shaded right wall from x = 365) and a darker
    /// floor below a slanted line through (365, 308), with aliased (staircase) edges.
    Room,
    /// All black (the `--black` fault).
    Black,
}

fn backdrop_pixel(b: Backdrop, x: usize, y: usize) -> [u8; 3] {
    match b {
        Backdrop::Wall => WALL,
        Backdrop::Black => [0; 3],
        Backdrop::Room => {
            let (xf, yf) = (x as f64, y as f64);
            let floor_y = if xf < 365.0 {
                308.0 + (365.0 - xf) * 0.104
            } else {
                308.0 + (xf - 365.0) * 0.13
            };
            if yf >= floor_y.round() {
                FLOOR
            } else if x >= 365 {
                WALL_SHADE
            } else {
                WALL
            }
        }
    }
}

fn overlap(a0: f64, a1: f64, b0: f64, b1: f64) -> f64 {
    (a1.min(b1) - a0.max(b0)).max(0.0)
}

/// A backdrop, rendered once, on which drone frames are drawn.
#[derive(Debug, Clone)]
pub struct Scene {
    backdrop: Backdrop,
    background: Vec<u8>,
}

impl Scene {
    pub fn new(backdrop: Backdrop) -> Self {
        let (w, h) = (usize::from(WIDTH), usize::from(HEIGHT));
        let mut background = vec![0u8; w * h * 3];
        for y in 0..h {
            for x in 0..w {
                background[(y * w + x) * 3..][..3].copy_from_slice(&backdrop_pixel(backdrop, x, y));
            }
        }
        Self {
            backdrop,
            background,
        }
    }

    /// One frame with the drone centred at `centre_px` (pixel-centre coordinates: pixel (i, j)
    /// covers [i − ½, i + ½] × [j − ½, j + ½]); `None` draws no drone. Black frames stay black.
    pub fn render(&self, centre_px: Option<[f64; 2]>) -> Vec<u8> {
        let mut rgb = self.background.clone();
        if self.backdrop == Backdrop::Black {
            return rgb;
        }
        let Some(c) = centre_px else { return rgb };
        let (w, h) = (usize::from(WIDTH), usize::from(HEIGHT));
        let x_lo = (c[0] - 25.0).floor().max(0.0) as usize;
        let x_hi = ((c[0] + 26.0).ceil().max(0.0) as usize).min(w);
        let y_lo = (c[1] - 7.0).floor().max(0.0) as usize;
        let y_hi = ((c[1] + 8.0).ceil().max(0.0) as usize).min(h);
        for y in y_lo..y_hi {
            for x in x_lo..x_hi {
                let (px0, px1) = (x as f64 - 0.5, x as f64 + 0.5);
                let (py0, py1) = (y as f64 - 0.5, y as f64 + 0.5);
                let mut grey = 0.0;
                let mut covered = 0.0;
                for r in &DRONE {
                    let a = overlap(px0, px1, c[0] + r[0], c[0] + r[1])
                        * overlap(py0, py1, c[1] + r[2], c[1] + r[3]);
                    covered += a;
                    grey += a * r[4];
                }
                if covered > 0.0 {
                    let px = &mut rgb[(y * w + x) * 3..][..3];
                    for ch in px.iter_mut() {
                        let v = grey + (1.0 - covered) * f64::from(*ch);
                        *ch = v.round().clamp(0.0, 255.0) as u8;
                    }
                }
            }
        }
        rgb
    }
}

/// An RGB frame message.
pub fn frame(seq: u64, rgb: Vec<u8>) -> RgbFrame {
    RgbFrame {
        seq,
        stamp_ns: (seq + 1) * PERIOD_NS,
        width: WIDTH,
        height: HEIGHT,
        valid: true,
        continuous: true,
        rgb,
    }
}

/// A labelled piece of a flight.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Piece {
    Rest,
    Action(Action),
}

/// A flight: the drone's image position at every 25 Hz frame, with the piece it belongs to.
#[derive(Debug, Clone, Default)]
pub struct Flight {
    pub points_px: Vec<[f64; 2]>,
    pub pieces: Vec<Piece>,
    /// Frame index at which each rest starts.
    pub rest_starts: Vec<usize>,
}

/// Minimum-jerk progress 0 → 1.
fn min_jerk(s: f64) -> f64 {
    let s = s.clamp(0.0, 1.0);
    s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)
}

impl Flight {
    pub fn rest(&mut self, duration_ns: u64) -> &mut Self {
        self.rest_starts.push(self.points_px.len());
        for _ in 0..duration_ns / PERIOD_NS {
            self.points_px.push(HOVER_PX);
            self.pieces.push(Piece::Rest);
        }
        self
    }

    /// Flies `action` from the hover point, strokes timed ∝ √length like the performer.
    pub fn action(&mut self, action: Action) -> &mut Self {
        let (sx, sy, duration_ns) = match action {
            Action::Start | Action::End => (AMPLITUDE_PX, AMPLITUDE_PX, 8_000_000_000u64),
            Action::Bit0 | Action::Bit1 => (BIT_WIDTH_PX, AMPLITUDE_PX, 6_000_000_000),
        };
        let pts: Vec<[f64; 2]> = action
            .image_polyline()
            .iter()
            .map(|p| [HOVER_PX[0] + p[0] * sx, HOVER_PX[1] + p[1] * sy])
            .collect();
        let weights: Vec<f64> = pts
            .windows(2)
            .map(|w| ((w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1])).sqrt())
            .collect();
        let total: f64 = weights.iter().sum();
        let frames = (duration_ns / PERIOD_NS) as usize;
        let mut bounds = vec![0.0];
        for w in &weights {
            bounds.push(bounds.last().unwrap() + w / total);
        }
        for k in 1..=frames {
            let t = k as f64 / frames as f64;
            let i = (0..weights.len())
                .find(|&i| t <= bounds[i + 1])
                .unwrap_or(weights.len() - 1);
            let s = min_jerk((t - bounds[i]) / (bounds[i + 1] - bounds[i]));
            let (a, b) = (pts[i], pts[i + 1]);
            self.points_px
                .push([a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1])]);
            self.pieces.push(Piece::Action(action));
        }
        self
    }

    /// `NULL START NULL b1 … NULL b6 NULL END NULL` for `payload` (b1 = most significant).
    pub fn offer(&mut self, payload: u8) -> &mut Self {
        self.rest(REST_NS).action(Action::Start);
        for k in 0..6 {
            self.rest(REST_NS)
                .action(Action::for_bit(payload >> (5 - k) & 1 == 1));
        }
        self.rest(REST_NS).action(Action::End).rest(REST_NS)
    }

    pub fn len(&self) -> usize {
        self.points_px.len()
    }
}
