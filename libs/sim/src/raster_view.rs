//! MuJoCo's scene handed to the Rust renderer ([`raster`]): the meshes of the compiled model
//! (vertices, faces and per-corner normals exactly as MuJoCo's renderer uploads them), and per
//! render the cameras, lights and geoms `mjv_updateScene` produced — the same input
//! `mjr_render` draws from, so both renderers show the same bodies, poses and materials.

use mujoco_rs::prelude::*;
use mujoco_rs::wrappers::mj_visualization::{MjvGLCamera, MjvGeom, MjvLight};
use raster::{Instance, Light, Mesh, MeshLods, RasterScene, Shape};

use crate::damage::pinhole;

/// Why MuJoCo's model or scene cannot be handed to the Rust renderer (what it does not draw, or
/// a mesh compiled inconsistently), naming the light, geom or mesh.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct ViewError(pub String);

/// The colour of pixels no geom covers (MuJoCo clears to black).
pub const BACKGROUND: [u8; 3] = [0, 0, 0];

/// Every mesh of `model` at every level of detail; a mesh MuJoCo compiled inconsistently is
/// refused naming it.
pub fn meshes(model: &MjModel) -> Result<Vec<MeshLods>, ViewError> {
    let n = usize::try_from(model.ffi().nmesh).unwrap_or(0);
    let (vert, face, normal, face_normal) = (
        model.mesh_vert(),
        model.mesh_face(),
        model.mesh_normal(),
        model.mesh_facenormal(),
    );
    (0..n)
        .map(|m| {
            let name = model
                .id_to_name(MjtObjBase::mjOBJ_MESH, m)
                .map_or_else(|| format!("#{m}"), str::to_owned);
            let range = |adr: i32, num: i32, len: usize| {
                let (a, k) = (usize::try_from(adr).ok()?, usize::try_from(num).ok()?);
                (a + k <= len).then_some(a..a + k)
            };
            let bad = || ViewError(format!("mesh {name}: address out of range"));
            let verts = range(model.mesh_vertadr()[m], model.mesh_vertnum()[m], vert.len())
                .ok_or_else(bad)?;
            let faces = range(model.mesh_faceadr()[m], model.mesh_facenum()[m], face.len())
                .ok_or_else(bad)?;
            let normals = range(
                model.mesh_normaladr()[m],
                model.mesh_normalnum()[m],
                normal.len(),
            )
            .ok_or_else(bad)?;
            let corner = |i: i32| -> Result<[f32; 3], ViewError> {
                usize::try_from(i)
                    .ok()
                    .and_then(|i| normal[normals.clone()].get(i).copied())
                    .ok_or_else(bad)
            };
            let triangles = face[faces.clone()]
                .iter()
                .map(|t| t.map(|v| u32::try_from(v).unwrap_or(u32::MAX)))
                .collect();
            let positions = &vert[verts.clone()];
            let corner_normals = face[faces.clone()]
                .iter()
                .zip(&face_normal[faces])
                .map(|(f, t)| {
                    let corners = [corner(t[0])?, corner(t[1])?, corner(t[2])?];
                    Ok(match face_normal_of(positions, *f) {
                        Some(n) => corners.map(|c| sharp(c, n)),
                        None => corners,
                    })
                })
                .collect::<Result<Vec<_>, ViewError>>()?;
            let mesh = Mesh::new(&name, vert[verts].to_vec(), triangles, corner_normals)
                .map_err(|e| ViewError(e.to_string()))?;
            Ok(MeshLods::build(mesh))
        })
        .collect()
}

/// The unit normal of face `f` (MuJoCo's `mjr_makeNormal`), `None` when degenerate or out of
/// range (the mesh check then names it).
fn face_normal_of(positions: &[[f32; 3]], f: [i32; 3]) -> Option<[f32; 3]> {
    let p = |i: i32| {
        positions
            .get(usize::try_from(i).ok()?)
            .map(|v| v.map(f64::from))
    };
    let (a, b, c) = (p(f[0])?, p(f[1])?, p(f[2])?);
    let (u, v) = (
        [b[0] - a[0], b[1] - a[1], b[2] - a[2]],
        [c[0] - a[0], c[1] - a[1], c[2] - a[2]],
    );
    let n = crate::vec3::cross(u, v);
    let len = crate::vec3::dot(n, n).sqrt();
    (len > 0.0).then(|| n.map(|x| (x / len) as f32))
}

/// MuJoCo's renderer shades a corner with the face's own normal where the mesh's corner normal
/// turns more than ≈ 37° from it (`mjr_uploadMesh`: a dot product under 0.8).
fn sharp(corner: [f32; 3], face: [f32; 3]) -> [f32; 3] {
    let d = corner[0] * face[0] + corner[1] * face[1] + corner[2] * face[2];
    if d < 0.8 { face } else { corner }
}

/// The renderer's input for one view: `None` for the camera when MuJoCo's camera cannot be
/// drawn by a pinhole (orthographic, degenerate).
pub fn scene(
    cameras: &[MjvGLCamera; 2],
    lights: &[MjvLight],
    geoms: &[MjvGeom],
    width: u16,
    height: u16,
) -> Result<RasterScene, ViewError> {
    let camera = pinhole(cameras, width, height)
        .ok_or_else(|| ViewError("the camera is not a perspective pinhole".into()))?;
    let lights = lights
        .iter()
        .map(light)
        .collect::<Result<Vec<_>, ViewError>>()?;
    let instances = geoms
        .iter()
        .map(instance)
        .collect::<Result<Vec<_>, ViewError>>()?;
    Ok(RasterScene {
        camera,
        lights,
        instances,
        background: BACKGROUND,
    })
}

fn light(l: &MjvLight) -> Result<Light, ViewError> {
    if l.type_ != MjtLightType::mjLIGHT_DIRECTIONAL as i32 {
        return Err(ViewError(format!(
            "light {} is not directional (type {}): the Rust renderer draws directional lights only",
            l.id, l.type_
        )));
    }
    let d = l.dir.map(f64::from);
    let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    if !(n.is_finite() && n > 0.0) {
        return Err(ViewError(format!("light {} has no direction", l.id)));
    }
    Ok(Light {
        to_light: d.map(|c| -c / n),
        ambient: l.ambient,
        diffuse: l.diffuse,
    })
}

fn instance(g: &MjvGeom) -> Result<Instance, ViewError> {
    use mujoco_rs::mujoco_c::mjtGeom::*;
    let size = g.size.map(f64::from);
    let shape = match g.type_ {
        t if t == mjGEOM_PLANE as i32 => Shape::Plane {
            half_m: [size[0], size[1]],
        },
        t if t == mjGEOM_BOX as i32 => Shape::Box { half_m: size },
        // mjvGeom names mesh m as 2m, and its convex hull as 2m + 1.
        t if t == mjGEOM_MESH as i32 => match usize::try_from(g.dataid) {
            Ok(d) if d % 2 == 0 => Shape::Mesh(d / 2),
            _ => {
                return Err(ViewError(format!(
                    "mesh geom {} is drawn as a convex hull or has no mesh (data {})",
                    g.objid, g.dataid
                )));
            }
        },
        t => {
            return Err(ViewError(format!(
                "geom {} is of type {t}: the Rust renderer draws planes, boxes and meshes",
                g.objid
            )));
        }
    };
    if g.transparent != 0 || g.rgba[3] < 1.0 || g.texid >= 0 || g.reflectance > 0.0 {
        return Err(ViewError(format!(
            "geom {} is transparent, textured or reflective: the Rust renderer draws opaque plain \
             colours",
            g.objid
        )));
    }
    let bound_m = match shape {
        Shape::Box { half_m: [x, y, z] } => Some((x * x + y * y + z * z).sqrt()),
        Shape::Plane { half_m: [x, y] } => Some((x * x + y * y).sqrt()),
        Shape::Mesh(_) => {
            // MuJoCo's own bounding radius, with slack for its f32 rounding.
            let r = f64::from(g.modelrbound);
            (r.is_finite() && r > 0.0).then_some(r * 1.01 + 1e-4)
        }
    };
    Ok(Instance {
        shape,
        pos_m: g.pos.map(f64::from),
        rot: g.mat.map(f64::from),
        rgb: [g.rgba[0], g.rgba[1], g.rgba[2]],
        emission: g.emission,
        bound_m,
    })
}
