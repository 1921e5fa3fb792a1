//! Synthetic event streams for receiver tests and benchmarks: frames drawn in code, converted by
//! the real event camera (`event-camera`), cut into 40 ms packets.
//!
//! The scene is a dark drone-sized bar (48×12 px, grey level 40, area-anti-aliased) on a uniform
//! mid-grey background (128), moved along the actions' keypoint polylines
//! ([`proto::Action::keypoints`], u right / v up → image x right / y down) with minimum-jerk
//! strokes whose durations are proportional to √(length), like the performer's. Renders run at
//! 100 Hz, packets at 25 Hz.

#![allow(dead_code)]

use event_camera::{CameraConfig, EventCamera};
use proto::{Action, EventPacket, Token};

pub const WIDTH: u16 = 640;
pub const HEIGHT: u16 = 480;
pub const RENDER_PERIOD_NS: u64 = 10_000_000;
pub const PACKET_PERIOD_NS: u64 = 40_000_000;
pub const NS_PER_S: u64 = 1_000_000_000;

pub const BACKGROUND: u8 = 128;
pub const BLOB_LEVEL: u8 = 40;
pub const BLOB_SIZE_PX: [f64; 2] = [48.0, 12.0];
/// The performer's hover point in the image (the optical centre).
pub const ORIGIN_PX: [f64; 2] = [320.0, 240.0];

/// Pixels per keypoint unit (u, v) of each action and of the acquisition sweep: 0.15 m ≈ 70 px
/// and the bits' 0.175 m width ≈ 80 px at the scene's 1.3 m.
pub fn scale_px(action: Option<Action>) -> [f64; 2] {
    match action {
        Some(Action::Bit0 | Action::Bit1) => [80.0, 70.0],
        _ => [70.0, 70.0],
    }
}

pub fn duration_ns(action: Option<Action>) -> u64 {
    match action {
        Some(Action::Start | Action::End) => 8 * NS_PER_S,
        Some(Action::Bit0 | Action::Bit1) => 5_800_000_000,
        None => 4 * NS_PER_S,
    }
}

/// One left–right pass returning to the centre (the performer's acquisition sweep).
pub const ACQUISITION_KEYPOINTS: [[f64; 2]; 4] = [[0.0, 0.0], [1.0, 0.0], [-1.0, 0.0], [0.0, 0.0]];

/// The target's silhouette.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// An axis-aligned 48×12 rectangle: straight edges fire all along at once (worst case for
    /// polarity balance).
    Bar,
    /// A 48×12 ellipse: edge pixels cross at different moments.
    Ellipse,
}

/// What the performer does during one span of the script.
#[derive(Debug, Clone, PartialEq)]
pub enum Label {
    Hold,
    /// A NULL rest of a frame.
    Null,
    Acquisition,
    Action(Action),
    /// Any other motion.
    Move,
}

#[derive(Debug, Clone, PartialEq)]
struct Stroke {
    from_px: [f64; 2],
    to_px: [f64; 2],
    start_ns: u64,
    end_ns: u64,
}

/// A labelled span `[start_ns, end_ns)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Span {
    pub label: Label,
    pub start_ns: u64,
    pub end_ns: u64,
}

/// The performer's image-plane script.
#[derive(Debug, Clone, PartialEq)]
pub struct Script {
    strokes: Vec<Stroke>,
    pub spans: Vec<Span>,
    here_px: [f64; 2],
    now_ns: u64,
    /// (from stamp, level): background grey level changes (lighting) — broad activity.
    background_changes: Vec<(u64, u8)>,
    pub shape: Shape,
}

impl Script {
    pub fn new() -> Self {
        Self {
            strokes: Vec::new(),
            spans: Vec::new(),
            here_px: ORIGIN_PX,
            now_ns: 0,
            background_changes: Vec::new(),
            shape: Shape::Bar,
        }
    }

    pub fn with_shape(mut self, shape: Shape) -> Self {
        self.shape = shape;
        self
    }

    pub fn duration_ns(&self) -> u64 {
        self.now_ns
    }

    pub fn hold(mut self, label: Label, ns: u64) -> Self {
        self.spans.push(Span {
            label,
            start_ns: self.now_ns,
            end_ns: self.now_ns + ns,
        });
        self.now_ns += ns;
        self
    }

    /// Flies `keypoints` (u right, v up units) scaled by `scale_px` from the current point.
    pub fn polyline(
        mut self,
        label: Label,
        keypoints: &[[f64; 2]],
        scale: [f64; 2],
        ns: u64,
    ) -> Self {
        let origin = self.here_px;
        let image: Vec<[f64; 2]> = keypoints
            .iter()
            .map(|k| [origin[0] + k[0] * scale[0], origin[1] - k[1] * scale[1]])
            .collect();
        let legs: Vec<([f64; 2], [f64; 2], f64)> = image
            .windows(2)
            .map(|w| (w[0], w[1], dist(w[0], w[1])))
            .filter(|l| l.2 > 0.0)
            .collect();
        let total: f64 = legs.iter().map(|l| l.2.sqrt()).sum();
        let start = self.now_ns;
        let mut t = start;
        for (i, &(from_px, to_px, len)) in legs.iter().enumerate() {
            let end = if i + 1 == legs.len() {
                start + ns
            } else {
                t + (ns as f64 * len.sqrt() / total) as u64
            };
            self.strokes.push(Stroke {
                from_px,
                to_px,
                start_ns: t,
                end_ns: end,
            });
            t = end;
        }
        self.spans.push(Span {
            label,
            start_ns: start,
            end_ns: start + ns,
        });
        self.here_px = *image.last().unwrap_or(&origin);
        self.now_ns = start + ns;
        self
    }

    pub fn action(self, action: Action) -> Self {
        self.polyline(
            Label::Action(action),
            action.keypoints(),
            scale_px(Some(action)),
            duration_ns(Some(action)),
        )
    }

    pub fn acquisition(self) -> Self {
        self.polyline(
            Label::Acquisition,
            &ACQUISITION_KEYPOINTS,
            scale_px(None),
            duration_ns(None),
        )
    }

    /// A frame after its first NULL: START, the six bits (b1 = most significant), END, each
    /// followed by a NULL rest of `null_ns`.
    pub fn frame_body(mut self, payload: u8, null_ns: u64) -> Self {
        self = self.action(Action::Start).hold(Label::Null, null_ns);
        for k in (0..6).rev() {
            self = self
                .action(Action::for_bit(payload >> k & 1 == 1))
                .hold(Label::Null, null_ns);
        }
        self.action(Action::End).hold(Label::Null, null_ns)
    }

    /// Lighting change: from `t_ns` on the background has grey `level`.
    pub fn background_change(mut self, t_ns: u64, level: u8) -> Self {
        self.background_changes.push((t_ns, level));
        self.background_changes.sort();
        self
    }

    /// The blob centre at `t_ns`.
    pub fn position_px(&self, t_ns: u64) -> [f64; 2] {
        let i = self.strokes.partition_point(|s| s.end_ns <= t_ns);
        match self.strokes.get(i) {
            Some(s) if t_ns >= s.start_ns => {
                let tau = (t_ns - s.start_ns) as f64 / (s.end_ns - s.start_ns) as f64;
                let m = tau * tau * tau * (10.0 - 15.0 * tau + 6.0 * tau * tau);
                [
                    s.from_px[0] + m * (s.to_px[0] - s.from_px[0]),
                    s.from_px[1] + m * (s.to_px[1] - s.from_px[1]),
                ]
            }
            Some(s) => s.from_px,
            None => self.strokes.last().map_or(ORIGIN_PX, |s| s.to_px),
        }
    }

    fn background_at(&self, t_ns: u64) -> u8 {
        self.background_changes
            .iter()
            .rev()
            .find(|c| c.0 <= t_ns)
            .map_or(BACKGROUND, |c| c.1)
    }

    /// Spans labelled as NULL rests.
    pub fn null_spans(&self) -> Vec<&Span> {
        self.spans
            .iter()
            .filter(|s| s.label == Label::Null)
            .collect()
    }
}

/// The standard stream of the brief: 1 s hover, acquisition sweep, 6 s quiet (the first NULL),
/// then the frame body with 4.5 s rests.
pub fn frame_script(payload: u8) -> Script {
    Script::new()
        .hold(Label::Hold, NS_PER_S)
        .acquisition()
        .hold(Label::Null, 6 * NS_PER_S)
        .frame_body(payload, 4_500_000_000)
}

/// The frame's 17 tokens.
pub fn frame_tokens(payload: u8) -> Vec<Token> {
    proto::frame::frame_tokens(payload).to_vec()
}

/// Draws the scene at `t_ns` into `rgb` (row-major RGB).
pub fn render(script: &Script, t_ns: u64, rgb: &mut [u8]) {
    let background = script.background_at(t_ns);
    rgb.fill(background);
    let c = script.position_px(t_ns);
    let (hw, hh) = (BLOB_SIZE_PX[0] / 2.0, BLOB_SIZE_PX[1] / 2.0);
    let (x0, x1) = (
        (c[0] - hw).floor().max(0.0) as usize,
        ((c[0] + hw).ceil() as usize).min(WIDTH as usize),
    );
    let (y0, y1) = (
        (c[1] - hh).floor().max(0.0) as usize,
        ((c[1] + hh).ceil() as usize).min(HEIGHT as usize),
    );
    let overlap =
        |p: usize, lo: f64, hi: f64| ((p as f64 + 1.0).min(hi) - (p as f64).max(lo)).max(0.0);
    for y in y0..y1 {
        let cy = overlap(y, c[1] - hh, c[1] + hh);
        for x in x0..x1 {
            let cover = match script.shape {
                Shape::Bar => cy * overlap(x, c[0] - hw, c[0] + hw),
                Shape::Ellipse => ellipse_cover(x, y, c, hw, hh),
            };
            let v = (f64::from(background) * (1.0 - cover) + f64::from(BLOB_LEVEL) * cover).round()
                as u8;
            let i = 3 * (y * WIDTH as usize + x);
            rgb[i..i + 3].fill(v);
        }
    }
}

/// Share of pixel (x, y) inside the ellipse of semi-axes (a, b) at `c`, by 4×4 supersampling.
fn ellipse_cover(x: usize, y: usize, c: [f64; 2], a: f64, b: f64) -> f64 {
    let mut inside = 0;
    for sy in 0..4 {
        for sx in 0..4 {
            let px = x as f64 + (sx as f64 + 0.5) / 4.0 - c[0];
            let py = y as f64 + (sy as f64 + 0.5) / 4.0 - c[1];
            if (px / a).powi(2) + (py / b).powi(2) <= 1.0 {
                inside += 1;
            }
        }
    }
    f64::from(inside) / 16.0
}

/// Renders `script` at 100 Hz from t = 0 through its end and converts it with the real event
/// camera (`black`: the camera's black-input fault). Returns every packet.
pub fn convert(script: &Script, black: bool) -> Vec<EventPacket> {
    convert_with(
        script,
        CameraConfig {
            black_input: black,
            ..CameraConfig::paper(WIDTH, HEIGHT)
        },
    )
}

/// [`convert`] through a camera of configuration `config` (e.g. a noisy sensor).
#[allow(
    dead_code,
    reason = "not every test binary converts through a noisy camera"
)]
pub fn convert_with(script: &Script, config: CameraConfig) -> Vec<EventPacket> {
    let mut camera = EventCamera::new(config).expect("paper camera");
    let mut rgb = vec![0u8; 3 * WIDTH as usize * HEIGHT as usize];
    let mut packets = Vec::new();
    let frames = script.duration_ns() / RENDER_PERIOD_NS;
    for k in 0..=frames {
        let t = k * RENDER_PERIOD_NS;
        render(script, t, &mut rgb);
        packets.extend(
            camera
                .push_frame(t, &rgb)
                .expect("frames of the camera's size"),
        );
    }
    packets
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
}
