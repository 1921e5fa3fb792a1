//! Which pixels of a camera's frame can differ from its previous render (pure: no GL).
//!
//! `mjr_render` is a deterministic function of the scene `mjv_updateScene` produced (cameras,
//! lights, geoms). This crate's scene has no shadows, reflections, fog, skybox or multisampling
//! (see [`crate::mjcf`]), so a geom's fragments only land inside its own projection. Hence:
//!
//! - same cameras, lights and geoms, bit for bit: the frame is the previous frame;
//! - same cameras and lights, same geom identities in the same order, some geoms changed: only
//!   pixels inside the union of the changed geoms' projected bounding spheres, before and after,
//!   can differ;
//! - anything else (the camera moved, a geom appeared, a geom without a model bounding sphere
//!   changed, a sphere reaches behind the near plane): the whole frame can differ.

use mujoco_rs::wrappers::mj_visualization::{MjvGLCamera, MjvGeom, MjvLight};
use proto::{FrameChange, PixelRect};

use crate::vec3::{cross, dot};

/// Pixels added around each projected sphere: covers rasterisation rules and the f32 rounding
/// of MuJoCo's projection against this module's f64 one.
const MARGIN_PX: f64 = 2.0;
/// Above this fraction of the frame a damage render costs about what a full one does.
const FULL_ABOVE: f64 = 0.5;

/// What one render consumed, kept to compare the next render's scene against.
#[derive(Clone)]
pub struct Snapshot {
    cameras: [MjvGLCamera; 2],
    lights: Vec<MjvLight>,
    geoms: Vec<MjvGeom>,
}

impl Snapshot {
    pub fn new(cameras: [MjvGLCamera; 2], lights: &[MjvLight], geoms: &[MjvGeom]) -> Self {
        Self {
            cameras,
            lights: lights.to_vec(),
            geoms: geoms.to_vec(),
        }
    }
}

/// How the frame of `now` (a `width`×`height` image) differs from the one rendered at `before`.
pub fn change(before: Option<&Snapshot>, now: &Snapshot, width: u16, height: u16) -> FrameChange {
    let Some(before) = before else {
        return FrameChange::All;
    };
    let cameras_same = before
        .cameras
        .iter()
        .zip(&now.cameras)
        .all(|(a, b)| same_camera(a, b));
    let lights_same = before.lights.len() == now.lights.len()
        && before
            .lights
            .iter()
            .zip(&now.lights)
            .all(|(a, b)| same_light(a, b));
    if !(cameras_same && lights_same) || before.geoms.len() != now.geoms.len() {
        return FrameChange::All;
    }
    let view = pinhole(&now.cameras, width, height);
    let mut bounds: Option<Bounds> = None;
    for (a, b) in before.geoms.iter().zip(&now.geoms) {
        if same_geom(a, b) {
            continue;
        }
        if !same_identity(a, b) {
            return FrameChange::All;
        }
        for g in [a, b] {
            let Some(view) = &view else {
                return FrameChange::All;
            };
            let Some(bound) = project(view, g) else {
                return FrameChange::All;
            };
            bounds = Some(bounds.map_or(bound, |u| u.union(bound)));
        }
    }
    let Some(bounds) = bounds else {
        return FrameChange::Nothing;
    };
    match bounds.clip(width, height) {
        None => FrameChange::Nothing,
        Some(rect) if rect.area_px() as f64 > FULL_ABOVE * f64::from(width) * f64::from(height) => {
            FrameChange::All
        }
        Some(rect) => FrameChange::Within(rect),
    }
}

/// A window-coordinate box (x right, y up from the bottom row), in pixels.
#[derive(Debug, Clone, Copy)]
struct Bounds {
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
}

impl Bounds {
    fn union(self, o: Bounds) -> Bounds {
        Bounds {
            x0: self.x0.min(o.x0),
            x1: self.x1.max(o.x1),
            y0: self.y0.min(o.y0),
            y1: self.y1.max(o.y1),
        }
    }

    /// The whole pixels the box touches, as an image rectangle (top row first); `None` if none.
    fn clip(self, width: u16, height: u16) -> Option<PixelRect> {
        let (w, h) = (f64::from(width), f64::from(height));
        let x0 = (self.x0 - MARGIN_PX).floor().clamp(0.0, w);
        let x1 = (self.x1 + MARGIN_PX).ceil().clamp(0.0, w);
        let y0 = (self.y0 - MARGIN_PX).floor().clamp(0.0, h);
        let y1 = (self.y1 + MARGIN_PX).ceil().clamp(0.0, h);
        if x1 <= x0 || y1 <= y0 {
            return None;
        }
        // Window rows count up from the bottom; image rows down from the top.
        Some(PixelRect {
            x: x0 as u16,
            y: (h - y1) as u16,
            width: (x1 - x0) as u16,
            height: (y1 - y0) as u16,
        })
    }
}

/// The perspective camera `mjr_render` uses for a mono view, as a pinhole of `width`×`height`:
/// the average of the scene's two cameras, a `glFrustum` whose half-width follows the viewport's
/// aspect unless set, and `mjr_lookAt`'s right/up/forward frame. The Rust renderer draws with
/// the same pinhole. `None`: orthographic or degenerate.
pub(crate) fn pinhole(
    cameras: &[MjvGLCamera; 2],
    width: u16,
    height: u16,
) -> Option<raster::Camera> {
    let [a, b] = cameras;
    if a.orthographic != 0 || b.orthographic != 0 {
        return None;
    }
    let avg =
        |p: [f32; 3], q: [f32; 3]| [0, 1, 2].map(|k| 0.5 * (f64::from(p[k]) + f64::from(q[k])));
    let forward = normalize(avg(a.forward, b.forward))?;
    let up_hint = normalize(avg(a.up, b.up))?;
    let right = normalize(cross(forward, up_hint))?;
    let up = cross(right, forward);
    let mid = |p: f32, q: f32| 0.5 * (f64::from(p) + f64::from(q));
    let (w, h) = (f64::from(width), f64::from(height));
    let (bottom, top) = (
        mid(a.frustum_bottom, b.frustum_bottom),
        mid(a.frustum_top, b.frustum_top),
    );
    let frustum_width = mid(a.frustum_width, b.frustum_width);
    let half_width = if frustum_width != 0.0 {
        frustum_width
    } else {
        0.5 * w / h * (top - bottom)
    };
    let center = mid(a.frustum_center, b.frustum_center);
    let (l, r) = (center - half_width, center + half_width);
    let near = mid(a.frustum_near, b.frustum_near);
    if !(near > 0.0 && r > l && top > bottom) {
        return None;
    }
    // NDC x = 2n/(r−l)·(x/d) − (r+l)/(r−l); window x = (NDC x + 1)·w/2 (same for y).
    Some(raster::Camera {
        pos_m: avg(a.pos, b.pos),
        right,
        up,
        forward,
        near_m: near,
        sx: near / (r - l) * w,
        ox: (1.0 - (r + l) / (r - l)) * 0.5 * w,
        sy: near / (top - bottom) * h,
        oy: (1.0 - (top + bottom) / (top - bottom)) * 0.5 * h,
        width_px: width,
        height_px: height,
    })
}

/// The window box of `g`'s bounding sphere; `None` when it cannot be bounded (no model sphere,
/// or the sphere reaches the near plane).
fn project(camera: &raster::Camera, g: &MjvGeom) -> Option<Bounds> {
    let radius = f64::from(g.modelrbound);
    if !(radius.is_finite() && radius > 0.0) {
        return None;
    }
    // Slack for the f32 pose and MuJoCo's own rounding of the bounding radius.
    let radius = radius * 1.01 + 1e-4;
    let [x0, y0, x1, y1] = camera.sphere_window_box(g.pos.map(f64::from), radius)?;
    Some(Bounds { x0, x1, y0, y1 })
}

fn normalize(a: [f64; 3]) -> Option<[f64; 3]> {
    let n = dot(a, a).sqrt();
    (n.is_finite() && n > 0.0).then(|| a.map(|v| v / n))
}

fn bits_eq(a: &[f32], b: &[f32]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

/// Same model object drawn the same way (what may not change for a damage render).
fn same_identity(a: &MjvGeom, b: &MjvGeom) -> bool {
    (
        a.type_, a.dataid, a.objtype, a.objid, a.category, a.matid, a.texid, a.segid,
    ) == (
        b.type_, b.dataid, b.objtype, b.objid, b.category, b.matid, b.texid, b.segid,
    ) && (a.texuniform, a.texcoord, a.transparent) == (b.texuniform, b.texcoord, b.transparent)
}

/// Every field `mjr_render` can read, bit for bit.
fn same_geom(a: &MjvGeom, b: &MjvGeom) -> bool {
    same_identity(a, b)
        && bits_eq(&a.size, &b.size)
        && bits_eq(&a.pos, &b.pos)
        && bits_eq(&a.mat, &b.mat)
        && bits_eq(&a.rgba, &b.rgba)
        && bits_eq(
            &[
                a.emission,
                a.specular,
                a.shininess,
                a.reflectance,
                a.camdist,
                a.modelrbound,
            ],
            &[
                b.emission,
                b.specular,
                b.shininess,
                b.reflectance,
                b.camdist,
                b.modelrbound,
            ],
        )
        && bits_eq(&a.texrepeat, &b.texrepeat)
        && a.label == b.label
}

fn same_light(a: &MjvLight, b: &MjvLight) -> bool {
    (a.id, a.type_, a.texid, a.headlight, a.castshadow)
        == (b.id, b.type_, b.texid, b.headlight, b.castshadow)
        && bits_eq(&a.pos, &b.pos)
        && bits_eq(&a.dir, &b.dir)
        && bits_eq(&a.attenuation, &b.attenuation)
        && bits_eq(&a.ambient, &b.ambient)
        && bits_eq(&a.diffuse, &b.diffuse)
        && bits_eq(&a.specular, &b.specular)
        && bits_eq(
            &[
                a.cutoff,
                a.exponent,
                a.bulbradius,
                a.intensity,
                a.range,
                a.softness,
            ],
            &[
                b.cutoff,
                b.exponent,
                b.bulbradius,
                b.intensity,
                b.range,
                b.softness,
            ],
        )
}

fn same_camera(a: &MjvGLCamera, b: &MjvGLCamera) -> bool {
    a.orthographic == b.orthographic
        && bits_eq(&a.pos, &b.pos)
        && bits_eq(&a.forward, &b.forward)
        && bits_eq(&a.up, &b.up)
        && bits_eq(
            &[
                a.frustum_center,
                a.frustum_width,
                a.frustum_bottom,
                a.frustum_top,
                a.frustum_near,
                a.frustum_far,
            ],
            &[
                b.frustum_center,
                b.frustum_width,
                b.frustum_bottom,
                b.frustum_top,
                b.frustum_near,
                b.frustum_far,
            ],
        )
}
