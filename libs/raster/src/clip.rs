//! Clipping in camera coordinates, before projection: against the near plane (what lies behind
//! it is not drawn, as in OpenGL) and against a guard band around the image, so that every
//! projected vertex stays within a few image widths and the fixed-point edge functions of
//! [`crate::fill`] cannot overflow. Attributes are interpolated linearly in camera space, which
//! is exact for a perspective camera.

use crate::scene::Camera;

/// A vertex in camera coordinates (x right, y up, d forward) with its lit colour.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClipVertex {
    pub p: [f64; 3],
    pub rgb: [f64; 3],
}

/// Pixels beyond each image edge that geometry may reach before it is clipped.
pub const GUARD_PX: f64 = 1024.0;

/// A half-space `a·x + b·y + c·d + e ≥ 0` of camera coordinates.
#[derive(Debug, Clone, Copy)]
struct Plane([f64; 4]);

impl Plane {
    fn eval(&self, v: &ClipVertex) -> f64 {
        let [a, b, c, e] = self.0;
        a * v.p[0] + b * v.p[1] + c * v.p[2] + e
    }
}

/// The five planes a camera clips against.
#[derive(Debug, Clone, Copy)]
pub struct Frustum {
    planes: [Plane; 5],
}

impl Frustum {
    pub fn new(camera: &Camera) -> Frustum {
        let (w, h) = (f64::from(camera.width_px), f64::from(camera.height_px));
        // window x = sx·x/d + ox ∈ [−G, w+G]  ⇔  sx·x + (ox+G)·d ≥ 0 and (w+G−ox)·d − sx·x ≥ 0
        // (for d > 0, which the near plane guarantees first).
        let g = GUARD_PX;
        Frustum {
            planes: [
                Plane([0.0, 0.0, 1.0, -camera.near_m]),
                Plane([camera.sx, 0.0, camera.ox + g, 0.0]),
                Plane([-camera.sx, 0.0, w + g - camera.ox, 0.0]),
                Plane([0.0, camera.sy, camera.oy + g, 0.0]),
                Plane([0.0, -camera.sy, h + g - camera.oy, 0.0]),
            ],
        }
    }

    /// Whether every vertex is inside every plane (the common case: no clipping needed).
    pub fn holds(&self, vs: &[ClipVertex]) -> bool {
        self.planes
            .iter()
            .all(|p| vs.iter().all(|v| p.eval(v) >= 0.0))
    }

    /// Clips triangle `tri` to the frustum; the result (0 or 3–8 vertices, convex, same
    /// winding) is written into `out`.
    pub fn clip(&self, tri: [ClipVertex; 3], out: &mut Polygon) {
        out.len = 3;
        out.v[..3].copy_from_slice(&tri);
        let mut scratch = Polygon::default();
        for plane in &self.planes {
            clip_one(out, plane, &mut scratch);
            std::mem::swap(out, &mut scratch);
            if out.len < 3 {
                out.len = 0;
                return;
            }
        }
    }
}

/// A convex polygon of at most 3 + 5 vertices.
#[derive(Debug, Clone, Copy)]
pub struct Polygon {
    pub v: [ClipVertex; 8],
    pub len: usize,
}

impl Default for Polygon {
    fn default() -> Self {
        Polygon {
            v: [ClipVertex {
                p: [0.0; 3],
                rgb: [0.0; 3],
            }; 8],
            len: 0,
        }
    }
}

impl Polygon {
    pub fn vertices(&self) -> &[ClipVertex] {
        &self.v[..self.len]
    }
}

/// Sutherland–Hodgman against one plane.
fn clip_one(input: &Polygon, plane: &Plane, out: &mut Polygon) {
    out.len = 0;
    let n = input.len;
    for i in 0..n {
        let a = input.v[i];
        let b = input.v[(i + 1) % n];
        let (fa, fb) = (plane.eval(&a), plane.eval(&b));
        if fa >= 0.0 {
            push(out, a);
        }
        if (fa >= 0.0) != (fb >= 0.0) {
            let t = fa / (fa - fb);
            push(out, lerp(&a, &b, t));
        }
    }
}

fn push(out: &mut Polygon, v: ClipVertex) {
    // A convex polygon clipped by one plane gains at most one vertex; 3 + 5 planes fit in 8.
    if out.len < out.v.len() {
        out.v[out.len] = v;
        out.len += 1;
    }
}

fn lerp(a: &ClipVertex, b: &ClipVertex, t: f64) -> ClipVertex {
    let mix = |x: f64, y: f64| x + (y - x) * t;
    ClipVertex {
        p: [0, 1, 2].map(|k| mix(a.p[k], b.p[k])),
        rgb: [0, 1, 2].map(|k| mix(a.rgb[k], b.rgb[k])),
    }
}
