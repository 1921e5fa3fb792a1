//! What one render draws: a pinhole camera in window coordinates, directional lights and
//! opaque instances of planes, boxes and meshes, each with its world pose and colour.

/// A pinhole camera. A point at camera coordinates (x right, y up, d forward, d > 0) lands at
/// window x = `sx`·x/d + `ox` and window y = `sy`·y/d + `oy` (y up from the bottom row, pixel
/// centres at half-integers), as OpenGL's viewport transform puts it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    pub pos_m: [f64; 3],
    pub right: [f64; 3],
    pub up: [f64; 3],
    pub forward: [f64; 3],
    /// Near clipping distance along `forward`, m.
    pub near_m: f64,
    pub sx: f64,
    pub ox: f64,
    pub sy: f64,
    pub oy: f64,
    pub width_px: u16,
    pub height_px: u16,
}

impl Camera {
    /// `p` in camera coordinates (x right, y up, d forward).
    pub fn to_camera(&self, p: [f64; 3]) -> [f64; 3] {
        let rel = [
            p[0] - self.pos_m[0],
            p[1] - self.pos_m[1],
            p[2] - self.pos_m[2],
        ];
        [
            dot(rel, self.right),
            dot(rel, self.up),
            dot(rel, self.forward),
        ]
    }

    /// The window box (x right, y up from the bottom row, in pixels, unclipped) that a sphere
    /// of `radius_m` at world `centre_m` covers, as `[x0, y0, x1, y1]`; `None` when the sphere
    /// reaches the near plane or is not finite. The damage rule (`sim::damage`) bounds MuJoCo's
    /// frames with it too.
    pub fn sphere_window_box(&self, centre_m: [f64; 3], radius_m: f64) -> Option<[f64; 4]> {
        let [x, y, d] = self.to_camera(centre_m);
        let r = radius_m;
        if !(x.is_finite() && y.is_finite() && r.is_finite() && d - r > self.near_m) {
            return None;
        }
        // Inside the box x±r, y±r, d±r with d−r > 0, x/d is monotonic in each coordinate: the
        // extremes are at its corners.
        let extremes = |c: f64| {
            let q = [
                (c - r) / (d - r),
                (c - r) / (d + r),
                (c + r) / (d - r),
                (c + r) / (d + r),
            ];
            (
                q.iter().copied().fold(f64::INFINITY, f64::min),
                q.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            )
        };
        let (tx0, tx1) = extremes(x);
        let (ty0, ty1) = extremes(y);
        Some([
            self.sx * tx0 + self.ox,
            self.sy * ty0 + self.oy,
            self.sx * tx1 + self.ox,
            self.sy * ty1 + self.oy,
        ])
    }

    /// [`Camera::sphere_window_box`] in image coordinates (x right, y down from the top row),
    /// as `[x0, y0, x1, y1]`.
    pub fn sphere_box(&self, centre_m: [f64; 3], radius_m: f64) -> Option<[f64; 4]> {
        let [x0, y0, x1, y1] = self.sphere_window_box(centre_m, radius_m)?;
        let h = f64::from(self.height_px);
        Some([x0, h - y1, x1, h - y0])
    }

    /// The radius in pixels a sphere of `radius_m` at camera depth `depth_m` appears with.
    pub fn projected_radius_px(&self, radius_m: f64, depth_m: f64) -> f64 {
        radius_m * self.sx.abs().max(self.sy.abs()) / depth_m.max(self.near_m)
    }
}

/// A directional light, as the fixed-function pipeline lights a vertex with it:
/// `ambient + diffuse · max(0, n · to_light)`, times the surface colour.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Light {
    /// Unit vector from the surface towards the light, world frame.
    pub to_light: [f64; 3],
    pub ambient: [f32; 3],
    pub diffuse: [f32; 3],
}

/// What an instance is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// A rectangle in the local x–y plane, facing +z, of these half sizes (m).
    Plane { half_m: [f64; 2] },
    /// A box of these half sizes (m).
    Box { half_m: [f64; 3] },
    /// Mesh number `n` of the scene's meshes.
    Mesh(usize),
}

/// One opaque object in the world.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Instance {
    pub shape: Shape,
    pub pos_m: [f64; 3],
    /// Row-major rotation, local to world (MuJoCo's `xmat`).
    pub rot: [f64; 9],
    pub rgb: [f32; 3],
    /// Emission, times `rgb` (MuJoCo's material emission).
    pub emission: f32,
    /// Radius of a sphere about `pos_m` that holds the whole shape, m; `None`: not bounded
    /// (never culled).
    pub bound_m: Option<f64>,
}

/// A frame's content.
#[derive(Debug, Clone, PartialEq)]
pub struct RasterScene {
    pub camera: Camera,
    pub lights: Vec<Light>,
    pub instances: Vec<Instance>,
    /// The colour of pixels no instance covers.
    pub background: [u8; 3],
}

/// An image rectangle, x right and y down from the top-left pixel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Rect {
    pub x: u16,
    pub y: u16,
    pub width: u16,
    pub height: u16,
}

impl Rect {
    pub fn full(width: u16, height: u16) -> Rect {
        Rect {
            x: 0,
            y: 0,
            width,
            height,
        }
    }

    pub fn area_px(&self) -> usize {
        usize::from(self.width) * usize::from(self.height)
    }

    /// Whether the pixel box `[x0, x1) × [y0, y1)` (fractional, unclipped) touches this rect.
    pub fn touches(&self, b: [f64; 4]) -> bool {
        let (rx0, ry0) = (f64::from(self.x), f64::from(self.y));
        let (rx1, ry1) = (rx0 + f64::from(self.width), ry0 + f64::from(self.height));
        b[0] < rx1 && b[2] > rx0 && b[1] < ry1 && b[3] > ry0
    }
}

pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `rot · v` for a row-major 3×3 rotation.
pub(crate) fn rotate(rot: &[f64; 9], v: [f64; 3]) -> [f64; 3] {
    [
        rot[0] * v[0] + rot[1] * v[1] + rot[2] * v[2],
        rot[3] * v[0] + rot[4] * v[1] + rot[5] * v[2],
        rot[6] * v[0] + rot[7] * v[1] + rot[8] * v[2],
    ]
}
