//! Deterministic synthetic scenes standing in for rendered frames in tests and benchmarks.
//!
//! A static textured background (sky gradient, tiled floor with fixed noise) and an
//! anti-aliased two-tone blob sweeping left–right, like the performer seen by an observer: most
//! pixels repeat exactly from frame to frame, a band around the blob changes.

use proto::{FrameChange, PixelRect};

/// A static background with one moving blob.
#[derive(Clone)]
pub struct MovingBlobScene {
    width: usize,
    height: usize,
    background: Vec<u8>,
    /// Blob radius, pixels.
    pub radius_px: f64,
    /// Peak horizontal excursion from the image centre, pixels.
    pub amplitude_px: f64,
    /// Sweep period, nanoseconds.
    pub period_ns: u64,
}

/// Cheap deterministic hash noise in 0..=255.
fn noise(x: usize, y: usize) -> u8 {
    let mut h = (x as u32).wrapping_mul(0x9E37_79B1) ^ (y as u32).wrapping_mul(0x85EB_CA77);
    h ^= h >> 15;
    h = h.wrapping_mul(0x2C1B_3C6D);
    h ^= h >> 12;
    (h & 0xFF) as u8
}

impl MovingBlobScene {
    /// A scene of the given size; the blob is scaled to the image (radius = height / 16).
    pub fn new(width: u16, height: u16) -> Self {
        let (width, height) = (usize::from(width), usize::from(height));
        let mut background = vec![0; width * height * 3];
        let horizon = height * 9 / 20;
        for y in 0..height {
            for x in 0..width {
                let px = &mut background[3 * (y * width + x)..][..3];
                if y < horizon {
                    let shade = (60 * y / horizon.max(1)) as u8;
                    px.copy_from_slice(&[150 + shade / 2, 185 + shade / 3, 235 - shade / 4]);
                } else {
                    let tile = ((x / 40) + (y / 40)) % 2 == 0;
                    let base: u8 = if tile { 120 } else { 88 };
                    let n = noise(x, y) / 16; // 0..=15 of fixed texture
                    px.copy_from_slice(&[base + n, base + n / 2, base - 30 + n]);
                }
            }
        }
        Self {
            width,
            height,
            background,
            radius_px: height as f64 / 16.0,
            amplitude_px: width as f64 / 5.0,
            period_ns: 2_000_000_000,
        }
    }

    /// The scene at sim time `t_ns` as row-major RGB.
    pub fn frame(&self, t_ns: u64) -> Vec<u8> {
        let mut rgb = self.background.clone();
        self.draw_blob(t_ns, &mut rgb);
        rgb
    }

    /// The scene every `render_ns` from 0 to `until_ns`, each with the rectangle that differs
    /// from the render before (`All` for the first, `Nothing` when none differs): what a
    /// renderer's damage tracking hands the camera, so a camera fed these converts only what
    /// moved, as in a trial.
    pub fn renders(&self, until_ns: u64, render_ns: u64) -> Vec<(Vec<u8>, FrameChange)> {
        let frames: Vec<Vec<u8>> = (0..=until_ns / render_ns.max(1))
            .map(|k| self.frame(k * render_ns))
            .collect();
        let changes: Vec<FrameChange> = frames
            .iter()
            .enumerate()
            .map(|(k, rgb)| match k.checked_sub(1) {
                None => FrameChange::All,
                Some(p) => self.changed(&frames[p], rgb),
            })
            .collect();
        frames.into_iter().zip(changes).collect()
    }

    /// The smallest rectangle holding every pixel that differs between two renders.
    fn changed(&self, before: &[u8], after: &[u8]) -> FrameChange {
        let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0, 0);
        for (i, (a, b)) in after
            .chunks_exact(3)
            .zip(before.chunks_exact(3))
            .enumerate()
        {
            if a != b {
                let (x, y) = (i % self.width, i / self.width);
                (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
            }
        }
        if x0 == usize::MAX {
            return FrameChange::Nothing;
        }
        FrameChange::Within(PixelRect {
            x: x0 as u16,
            y: y0 as u16,
            width: (x1 - x0 + 1) as u16,
            height: (y1 - y0 + 1) as u16,
        })
    }

    /// Writes the scene at `t_ns` into `rgb` (must be `width·height·3` bytes).
    pub fn render_into(&self, t_ns: u64, rgb: &mut [u8]) {
        rgb.copy_from_slice(&self.background);
        self.draw_blob(t_ns, rgb);
    }

    fn draw_blob(&self, t_ns: u64, rgb: &mut [u8]) {
        let phase = (t_ns % self.period_ns) as f64 / self.period_ns as f64 * std::f64::consts::TAU;
        let cx = self.width as f64 / 2.0 + self.amplitude_px * phase.sin();
        let cy = self.height as f64 / 2.0 + 0.15 * self.amplitude_px * (2.0 * phase).sin();
        let r = self.radius_px;
        let x0 = (cx - r - 1.0).floor().max(0.0) as usize;
        let x1 = ((cx + r + 2.0).ceil() as usize).min(self.width);
        let y0 = (cy - r - 1.0).floor().max(0.0) as usize;
        let y1 = ((cy + r + 2.0).ceil() as usize).min(self.height);
        for y in y0..y1 {
            for x in x0..x1 {
                let dist = ((x as f64 + 0.5 - cx).powi(2) + (y as f64 + 0.5 - cy).powi(2)).sqrt();
                let cover = (r + 0.5 - dist).clamp(0.0, 1.0);
                if cover == 0.0 {
                    continue;
                }
                // Dark body with a lighter ring, so the blob has inner edges too.
                let colour: [f64; 3] = if dist < 0.55 * r {
                    [40.0, 42.0, 48.0]
                } else {
                    [95.0, 90.0, 85.0]
                };
                let px = &mut rgb[3 * (y * self.width + x)..][..3];
                for (p, c) in px.iter_mut().zip(colour) {
                    *p = (f64::from(*p) * (1.0 - cover) + c * cover).round() as u8;
                }
            }
        }
    }
}
