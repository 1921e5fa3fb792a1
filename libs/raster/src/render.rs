//! One frame, or one rectangle of it: cull the instances whose bounding spheres miss the
//! rectangle, choose each mesh's level from its projected size, light every corner as the
//! fixed-function pipeline does (per vertex, clamped, then interpolated), transform, clip,
//! cull back faces and fill.

use crate::clip::{ClipVertex, Frustum, Polygon};
use crate::fill::{self, SUBPIXEL, ScreenVertex, Target};
use crate::mesh::MeshLods;
use crate::scene::{Camera, Instance, Light, RasterScene, Rect, Shape, dot, rotate};

/// Pixels added around a projected bounding sphere before it is tested against the rectangle:
/// covers the snapping of vertices to 1/256 px.
const CULL_MARGIN_PX: f64 = 1.0;

/// What one render did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RenderStats {
    pub instances_drawn: u64,
    pub instances_culled: u64,
    pub triangles_submitted: u64,
    pub pixels_written: u64,
}

impl std::ops::AddAssign for RenderStats {
    fn add_assign(&mut self, o: RenderStats) {
        self.instances_drawn += o.instances_drawn;
        self.instances_culled += o.instances_culled;
        self.triangles_submitted += o.triangles_submitted;
        self.pixels_written += o.pixels_written;
    }
}

/// Why a render was refused.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum RasterError {
    #[error("frame buffer holds {got} bytes, a {width}×{height} RGB frame needs {want}")]
    FrameSize {
        got: usize,
        want: usize,
        width: u16,
        height: u16,
    },
    #[error("rectangle {rect:?} is not inside the {width}×{height} frame")]
    Rect { rect: Rect, width: u16, height: u16 },
    #[error("instance {index} names mesh {mesh}, the scene has {meshes}")]
    NoMesh {
        index: usize,
        mesh: usize,
        meshes: usize,
    },
}

/// The renderer: the scene's meshes and the scratch space of its renders.
pub struct Renderer {
    meshes: Vec<MeshLods>,
    depth: Vec<f32>,
    scratch: Scratch,
    /// Forced level of detail (tests and benches); `None`: chosen per instance.
    forced_level: Option<usize>,
    /// Every render's statistics, added up.
    total: RenderStats,
}

impl Renderer {
    pub fn new(meshes: Vec<MeshLods>) -> Renderer {
        Renderer {
            meshes,
            depth: Vec::new(),
            scratch: Scratch::default(),
            forced_level: None,
            total: RenderStats::default(),
        }
    }

    /// Every render's statistics so far, added up.
    pub fn total(&self) -> RenderStats {
        self.total
    }

    pub fn meshes(&self) -> &[MeshLods] {
        &self.meshes
    }

    /// Draw every mesh at this level (clamped to its coarsest), or `None` to choose by size.
    pub fn force_level(&mut self, level: Option<usize>) {
        self.forced_level = level;
    }

    /// Renders the pixels of `rect` of `scene` into `rgb` (the whole frame, row-major RGB, top
    /// row first); pixels outside `rect` are left as they are.
    pub fn render(
        &mut self,
        scene: &RasterScene,
        rect: Rect,
        rgb: &mut [u8],
    ) -> Result<RenderStats, RasterError> {
        let cam = &scene.camera;
        let (w, h) = (cam.width_px, cam.height_px);
        let want = usize::from(w) * usize::from(h) * 3;
        if rgb.len() != want {
            return Err(RasterError::FrameSize {
                got: rgb.len(),
                want,
                width: w,
                height: h,
            });
        }
        if u32::from(rect.x) + u32::from(rect.width) > u32::from(w)
            || u32::from(rect.y) + u32::from(rect.height) > u32::from(h)
        {
            return Err(RasterError::Rect {
                rect,
                width: w,
                height: h,
            });
        }
        for (index, inst) in scene.instances.iter().enumerate() {
            if let Shape::Mesh(mesh) = inst.shape
                && mesh >= self.meshes.len()
            {
                return Err(RasterError::NoMesh {
                    index,
                    mesh,
                    meshes: self.meshes.len(),
                });
            }
        }
        let mut stats = RenderStats::default();
        if rect.area_px() == 0 {
            return Ok(stats);
        }
        let stride = usize::from(w);
        for row in usize::from(rect.y)..usize::from(rect.y) + usize::from(rect.height) {
            let start = (row * stride + usize::from(rect.x)) * 3;
            for px in rgb[start..start + usize::from(rect.width) * 3].chunks_exact_mut(3) {
                px.copy_from_slice(&scene.background);
            }
        }
        self.depth.clear();
        self.depth.resize(rect.area_px(), 0.0);
        let frustum = Frustum::new(cam);
        let mut target = Target {
            rgb,
            stride_px: stride,
            depth: &mut self.depth,
            rect,
        };
        for inst in &scene.instances {
            let level = match visible_level(cam, inst, rect) {
                None => {
                    stats.instances_culled += 1;
                    continue;
                }
                Some(radius_px) => radius_px,
            };
            stats.instances_drawn += 1;
            let mut draw = Draw {
                cam,
                frustum: &frustum,
                target: &mut target,
                stats: &mut stats,
            };
            match inst.shape {
                Shape::Plane { half_m } => {
                    let [x, y] = half_m;
                    let quad = [[-x, -y, 0.0], [x, -y, 0.0], [x, y, 0.0], [-x, y, 0.0]];
                    draw.face(inst, &scene.lights, quad, [0.0, 0.0, 1.0]);
                }
                Shape::Box { half_m } => {
                    for (normal, quad) in box_faces(half_m) {
                        draw.face(inst, &scene.lights, quad, normal);
                    }
                }
                Shape::Mesh(m) => {
                    let lods = &self.meshes[m];
                    let k = match (self.forced_level, level) {
                        (Some(k), _) => k.min(lods.levels().len() - 1),
                        (None, Some(radius_px)) => lods.level_for(radius_px),
                        (None, None) => 0,
                    };
                    draw.mesh(inst, &scene.lights, lods, k, &mut self.scratch);
                }
            }
        }
        self.total += stats;
        Ok(stats)
    }
}

/// `None`: the instance's bounding sphere misses `rect`. `Some(Some(r))`: drawn, appearing
/// `r` px in radius; `Some(None)`: drawn, size unknown (unbounded, or reaching the near plane).
fn visible_level(cam: &Camera, inst: &Instance, rect: Rect) -> Option<Option<f64>> {
    let Some(radius_m) = inst.bound_m else {
        return Some(None);
    };
    let Some(b) = cam.sphere_box(inst.pos_m, radius_m) else {
        return Some(None);
    };
    let m = CULL_MARGIN_PX;
    if !rect.touches([b[0] - m, b[1] - m, b[2] + m, b[3] + m]) {
        return None;
    }
    let depth_m = cam.to_camera(inst.pos_m)[2];
    Some(Some(cam.projected_radius_px(radius_m, depth_m)))
}

/// A box's six faces: outward normal and corners counter-clockwise seen from outside.
fn box_faces(half_m: [f64; 3]) -> [([f64; 3], [[f64; 3]; 4]); 6] {
    let [x, y, z] = half_m;
    [
        (
            [1.0, 0.0, 0.0],
            [[x, -y, -z], [x, y, -z], [x, y, z], [x, -y, z]],
        ),
        (
            [-1.0, 0.0, 0.0],
            [[-x, y, -z], [-x, -y, -z], [-x, -y, z], [-x, y, z]],
        ),
        (
            [0.0, 1.0, 0.0],
            [[x, y, -z], [-x, y, -z], [-x, y, z], [x, y, z]],
        ),
        (
            [0.0, -1.0, 0.0],
            [[-x, -y, -z], [x, -y, -z], [x, -y, z], [-x, -y, z]],
        ),
        (
            [0.0, 0.0, 1.0],
            [[-x, -y, z], [x, -y, z], [x, y, z], [-x, y, z]],
        ),
        (
            [0.0, 0.0, -1.0],
            [[-x, y, -z], [x, y, -z], [x, -y, -z], [-x, -y, -z]],
        ),
    ]
}

/// The fixed-function lit colour of a surface of colour `rgb` with world normal `n`, clamped.
pub fn lit(inst: &Instance, lights: &[Light], n: [f64; 3]) -> [f64; 3] {
    let base = inst.rgb.map(f64::from);
    let mut c = base.map(|b| f64::from(inst.emission) * b);
    for l in lights {
        let diffuse = dot(n, l.to_light).max(0.0);
        for k in 0..3 {
            c[k] += base[k] * (f64::from(l.ambient[k]) + f64::from(l.diffuse[k]) * diffuse);
        }
    }
    c.map(|v| v.clamp(0.0, 1.0))
}

struct Draw<'a, 'b> {
    cam: &'a Camera,
    frustum: &'a Frustum,
    target: &'a mut Target<'b>,
    stats: &'a mut RenderStats,
}

/// An instance's pose composed with the camera: camera coordinates = `m` · local + `t`.
struct Pose {
    m: [f64; 9],
    t: [f64; 3],
}

impl Pose {
    fn new(cam: &Camera, inst: &Instance) -> Pose {
        let rows = [cam.right, cam.up, cam.forward];
        let r = &inst.rot;
        let mut m = [0.0; 9];
        for (i, row) in rows.iter().enumerate() {
            for j in 0..3 {
                m[3 * i + j] = row[0] * r[j] + row[1] * r[3 + j] + row[2] * r[6 + j];
            }
        }
        Pose {
            m,
            t: cam.to_camera(inst.pos_m),
        }
    }

    fn apply(&self, p: [f64; 3]) -> [f64; 3] {
        let m = &self.m;
        [
            m[0] * p[0] + m[1] * p[1] + m[2] * p[2] + self.t[0],
            m[3] * p[0] + m[4] * p[1] + m[5] * p[2] + self.t[1],
            m[6] * p[0] + m[7] * p[1] + m[8] * p[2] + self.t[2],
        ]
    }
}

/// The lights turned into an instance's own frame (`rotᵀ · to_light`), so that a local normal
/// is lit without being rotated.
fn local_lights(inst: &Instance, lights: &[Light]) -> Vec<Light> {
    let r = &inst.rot;
    lights
        .iter()
        .map(|l| {
            let d = l.to_light;
            Light {
                to_light: [
                    r[0] * d[0] + r[3] * d[1] + r[6] * d[2],
                    r[1] * d[0] + r[4] * d[1] + r[7] * d[2],
                    r[2] * d[0] + r[5] * d[1] + r[8] * d[2],
                ],
                ..*l
            }
        })
        .collect()
}

impl Draw<'_, '_> {
    /// A flat quad (local corners, local normal): one colour, two triangles.
    fn face(&mut self, inst: &Instance, lights: &[Light], quad: [[f64; 3]; 4], normal: [f64; 3]) {
        let rgb = lit(inst, lights, rotate(&inst.rot, normal));
        let pose = Pose::new(self.cam, inst);
        let v = quad.map(|p| ClipVertex {
            p: pose.apply(p),
            rgb,
        });
        let flat = Some(rgb.map(fill::to_u8));
        self.triangle([v[0], v[1], v[2]], flat, true);
        self.triangle([v[0], v[2], v[3]], flat, true);
    }

    fn mesh(
        &mut self,
        inst: &Instance,
        lights: &[Light],
        lods: &MeshLods,
        level: usize,
        scratch: &mut Scratch,
    ) {
        let mesh = &lods.levels()[level];
        let pose = Pose::new(self.cam, inst);
        scratch.camera_space.clear();
        scratch.camera_space.extend(
            mesh.positions_m()
                .iter()
                .map(|p| pose.apply(p.map(f64::from))),
        );
        let local = local_lights(inst, lights);
        scratch.lit.clear();
        scratch.lit.extend(
            mesh.distinct_normals()
                .iter()
                .map(|n| lit(inst, &local, n.map(f64::from))),
        );
        // Whether the whole instance lies inside the frustum: then no triangle needs clipping.
        let inside = inst
            .bound_m
            .is_some_and(|r| sphere_inside(self.cam, pose.t, r));
        let (cs, lit_rgb) = (&scratch.camera_space, &scratch.lit);
        for (t, corners) in mesh.triangles().iter().zip(mesh.corner_normal()) {
            let p = t.map(|v| cs[v as usize]);
            // Back faces never reach the fill. (right, up, forward) is a left-handed frame,
            // so this cross product is minus the true normal: front faces have n · p > 0.
            let e1 = [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]];
            let e2 = [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]];
            let n = [
                e1[1] * e2[2] - e1[2] * e2[1],
                e1[2] * e2[0] - e1[0] * e2[2],
                e1[0] * e2[1] - e1[1] * e2[0],
            ];
            if dot(n, p[0]) <= 0.0 {
                continue;
            }
            let rgb = corners.map(|c| lit_rgb[c as usize]);
            let flat = (rgb[0] == rgb[1] && rgb[1] == rgb[2]).then(|| rgb[0].map(fill::to_u8));
            self.triangle(
                [0, 1, 2].map(|k| ClipVertex {
                    p: p[k],
                    rgb: rgb[k],
                }),
                flat,
                !inside,
            );
        }
    }

    fn triangle(&mut self, v: [ClipVertex; 3], flat: Option<[u8; 3]>, may_clip: bool) {
        self.stats.triangles_submitted += 1;
        let h = f64::from(self.cam.height_px);
        let project = |c: &ClipVertex| {
            let inv_d = 1.0 / c.p[2];
            let x = self.cam.sx * c.p[0] * inv_d + self.cam.ox;
            let y = h - (self.cam.sy * c.p[1] * inv_d + self.cam.oy);
            ScreenVertex {
                x: snap(x),
                y: snap(y),
                inv_d,
                rgb: c.rgb,
            }
        };
        if !may_clip || self.frustum.holds(&v) {
            let s = v.map(|c| project(&c));
            if front(&s) {
                self.stats.pixels_written += fill::triangle(self.target, s, flat);
            }
            return;
        }
        let mut poly = Polygon::default();
        self.frustum.clip(v, &mut poly);
        let vs = poly.vertices();
        if vs.len() < 3 {
            return;
        }
        let s: Vec<ScreenVertex> = vs.iter().map(project).collect();
        for k in 1..s.len() - 1 {
            let tri = [s[0], s[k], s[k + 1]];
            if front(&tri) {
                self.stats.pixels_written += fill::triangle(self.target, tri, flat);
            }
        }
    }
}

/// Per-render scratch of a mesh: its vertices in camera coordinates, its lit normals.
#[derive(Default)]
pub(crate) struct Scratch {
    camera_space: Vec<[f64; 3]>,
    lit: Vec<[f64; 3]>,
}

/// A pixel coordinate in 1/256 px, rounded half up (no libm call: exact for |v| < 2⁴⁴ px).
fn snap(v: f64) -> i64 {
    let s = v * SUBPIXEL as f64 + 0.5;
    let t = s as i64;
    t - i64::from((t as f64) > s)
}

/// Whether a sphere of `radius_m` at camera coordinates `c` lies inside the near plane and the
/// guard band, with a pixel to spare.
fn sphere_inside(cam: &Camera, c: [f64; 3], radius_m: f64) -> bool {
    let (x, y, d) = (c[0], c[1], c[2]);
    let r = radius_m;
    let clear_of_near = d - r > cam.near_m;
    if !clear_of_near {
        return false;
    }
    let g = crate::clip::GUARD_PX - 1.0;
    let (w, h) = (f64::from(cam.width_px), f64::from(cam.height_px));
    // The sphere's extreme ratios lie between (c ± r)/(d ± r).
    let lo = |c: f64| ((c - r) / (d - r)).min((c - r) / (d + r));
    let hi = |c: f64| ((c + r) / (d - r)).max((c + r) / (d + r));
    let xs = [cam.sx * lo(x) + cam.ox, cam.sx * hi(x) + cam.ox];
    let ys = [cam.sy * lo(y) + cam.oy, cam.sy * hi(y) + cam.oy];
    let within = |v: f64, size: f64| v > -g && v < size + g;
    xs.iter().all(|&v| within(v, w)) && ys.iter().all(|&v| within(v, h))
}

/// Counter-clockwise in window coordinates (y up) is clockwise in the image's (y down).
fn front(s: &[ScreenVertex; 3]) -> bool {
    let [a, b, c] = s;
    (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x) < 0
}
