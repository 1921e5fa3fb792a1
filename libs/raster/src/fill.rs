//! The triangle rasteriser: fixed-point edge functions, a top-left fill rule, a depth test on
//! 1/d, perspective-correct colour, into one rectangle of a frame.
//!
//! Vertices are snapped to 1/256 px; each row's covered span is solved exactly in integers from
//! the three edge functions, so a pixel is covered or not by the same rule on every machine and
//! two triangles sharing an edge never both draw, nor both miss, a pixel centre on it.

use crate::scene::Rect;

/// Sub-pixel steps per pixel (8 bits).
pub const SUBPIXEL: i64 = 256;

/// Up to this many columns a row is tested pixel by pixel rather than solved as a span.
const NARROW_PX: i64 = 12;

/// A projected vertex: image position (x right, y down) in 1/256 px, 1/d and its colour.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScreenVertex {
    pub x: i64,
    pub y: i64,
    pub inv_d: f64,
    pub rgb: [f64; 3],
}

/// Where a triangle is drawn: a frame's RGB (row-major, top row first, `stride_px` wide) and a
/// depth buffer covering exactly `rect`.
pub struct Target<'a> {
    pub rgb: &'a mut [u8],
    pub stride_px: usize,
    pub depth: &'a mut [f32],
    pub rect: Rect,
}

/// A colour channel in [0, 1] as the framebuffer stores it (round to nearest).
pub fn to_u8(c: f64) -> u8 {
    let c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
    (c * 255.0 + 0.5) as u8
}

/// One edge a→b: E(p) = dx·(p.y − a.y) − dy·(p.x − a.x), positive inside.
#[derive(Clone, Copy)]
struct Edge {
    /// E at the centre of the rectangle's first column, current row.
    row: i64,
    step_x: i64,
    step_y: i64,
    /// Least E that counts as inside: 0 on edges this triangle owns (top-left), else 1.
    least: i64,
}

impl Edge {
    fn new(a: &ScreenVertex, b: &ScreenVertex, x0: i64, y0: i64) -> Edge {
        let (dx, dy) = (b.x - a.x, b.y - a.y);
        // Any rule that gives an edge to exactly one of its two directions works; this one
        // owns edges going up the image, and horizontal ones going right.
        let owned = dy < 0 || (dy == 0 && dx > 0);
        Edge {
            row: dx * (y0 - a.y) - dy * (x0 - a.x),
            step_x: -dy * SUBPIXEL,
            step_y: dx * SUBPIXEL,
            least: i64::from(!owned),
        }
    }

    /// The columns k ≥ 0 of this row with row + k·step_x ≥ least, as [lo, hi).
    fn span(&self, width: i64) -> (i64, i64) {
        let need = self.least - self.row;
        if self.step_x == 0 {
            return if need <= 0 { (0, width) } else { (0, 0) };
        }
        if self.step_x > 0 {
            let lo = if need <= 0 {
                0
            } else {
                need.div_euclid(self.step_x) + i64::from(need.rem_euclid(self.step_x) != 0)
            };
            (lo.min(width), width)
        } else {
            // row + k·s ≥ least with s < 0: k ≤ (row − least) / |s|.
            let room = -need;
            if room < 0 {
                return (0, 0);
            }
            let hi = room.div_euclid(-self.step_x) + 1;
            (0, hi.min(width))
        }
    }
}

/// Draws triangle `v` (any winding; back faces must already be culled) into `target`; returns
/// the pixels written. `flat`: every corner has this colour (no interpolation).
pub fn triangle(target: &mut Target<'_>, v: [ScreenVertex; 3], flat: Option<[u8; 3]>) -> u64 {
    let [a, b, c] = v;
    let area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if area == 0 {
        return 0;
    }
    let [a, b, c] = if area > 0 { [a, b, c] } else { [a, c, b] };
    let area = area.abs();
    let rect = target.rect;
    // The pixel rows and columns whose centres can lie inside, within the rectangle.
    let min = |p: i64, q: i64, r: i64| p.min(q).min(r);
    let max = |p: i64, q: i64, r: i64| p.max(q).max(r);
    let first_px = |s: i64| (s - SUBPIXEL / 2).div_euclid(SUBPIXEL);
    let col0 = (first_px(min(a.x, b.x, c.x))).max(i64::from(rect.x));
    let col1 = (first_px(max(a.x, b.x, c.x)) + 1).min(i64::from(rect.x) + i64::from(rect.width));
    let row0 = (first_px(min(a.y, b.y, c.y))).max(i64::from(rect.y));
    let row1 = (first_px(max(a.y, b.y, c.y)) + 1).min(i64::from(rect.y) + i64::from(rect.height));
    if col0 >= col1 || row0 >= row1 {
        return 0;
    }
    let (cx, cy) = (
        col0 * SUBPIXEL + SUBPIXEL / 2,
        row0 * SUBPIXEL + SUBPIXEL / 2,
    );
    // Edge k is opposite vertex k: its function, over the area, is vertex k's weight.
    let mut edges = [
        Edge::new(&b, &c, cx, cy),
        Edge::new(&c, &a, cx, cy),
        Edge::new(&a, &b, cx, cy),
    ];
    let inv_area = 1.0 / area as f64;
    let z = [a.inv_d, b.inv_d, c.inv_d];
    let cz = [a, b, c].map(|p| p.rgb.map(|ch| ch * p.inv_d));
    let width = col1 - col0;
    let mut written = 0u64;
    for row in row0..row1 {
        let (mut lo, mut hi) = (0, width);
        if width > NARROW_PX {
            for e in &edges {
                let (l, h) = e.span(width);
                lo = lo.max(l);
                hi = hi.min(h);
            }
        }
        let rgb_row = row as usize * target.stride_px;
        let depth_row = (row - i64::from(rect.y)) as usize * usize::from(rect.width);
        for k in lo..hi {
            let e = edges.map(|e| e.row + k * e.step_x);
            // Narrow rows are tested pixel by pixel (the span's divisions cost more there);
            // the test is the same inequality the span solves.
            if width <= NARROW_PX && !(0..3).all(|i| e[i] >= edges[i].least) {
                continue;
            }
            let w = e.map(|v| v as f64 * inv_area);
            let inv_d = w[0] * z[0] + w[1] * z[1] + w[2] * z[2];
            let col = (col0 + k) as usize;
            let di = depth_row + (col - usize::from(rect.x));
            // GL_LEQUAL on depth: nearer or equal wins (larger 1/d is nearer).
            let inv_d32 = inv_d as f32;
            // Written so that a NaN depth never passes.
            let passes = inv_d32 >= target.depth[di];
            if !passes {
                continue;
            }
            target.depth[di] = inv_d32;
            let px = match flat {
                Some(rgb) => rgb,
                None => [0, 1, 2].map(|ch| {
                    to_u8((w[0] * cz[0][ch] + w[1] * cz[1][ch] + w[2] * cz[2][ch]) / inv_d)
                }),
            };
            let o = (rgb_row + col) * 3;
            target.rgb[o..o + 3].copy_from_slice(&px);
            written += 1;
        }
        for e in &mut edges {
            e.row += e.step_y;
        }
    }
    written
}
