//! The synthetic scene the renderer's tests and its bench draw: a floor, a wall and two
//! latitude–longitude balls under a headlight and a sun, seen by a level pinhole camera.

use raster::{Camera, Instance, Light, Mesh, RasterScene, Shape};

/// A closed ball of `n`×`n` quads on a latitude–longitude grid, normals pointing out.
pub fn ball(n: usize, radius_m: f32) -> Mesh {
    let mut p = Vec::new();
    for i in 0..=n {
        for j in 0..=n {
            // Only the fixture's geometry: trigonometry is fine here, never in a render.
            let (th, ph) = (
                std::f64::consts::PI * i as f64 / n as f64,
                2.0 * std::f64::consts::PI * j as f64 / n as f64,
            );
            p.push([
                (th.sin() * ph.cos()) as f32,
                (th.sin() * ph.sin()) as f32,
                th.cos() as f32,
            ]);
        }
    }
    let id = |i: usize, j: usize| (i * (n + 1) + j) as u32;
    let mut t = Vec::new();
    for i in 0..n {
        for j in 0..n {
            t.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            t.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    let normals = t.iter().map(|tri| tri.map(|v| p[v as usize])).collect();
    let scaled = p.iter().map(|q| q.map(|c| c * radius_m)).collect();
    Mesh::new("ball", scaled, t, normals).expect("mesh")
}

/// An opaque instance of `shape`, unrotated.
pub fn at(shape: Shape, pos_m: [f64; 3], rgb: [f32; 3], bound_m: Option<f64>) -> Instance {
    Instance {
        shape,
        pos_m,
        rot: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        rgb,
        emission: 0.0,
        bound_m,
    }
}

/// A `width`×`height` view along +y from `distance_m` before a ball of radius 0.1 m (mesh 0)
/// at 1 m height, a second ball (mesh 0) off to the side, the floor and the far wall.
pub fn scene(width: u16, height: u16, focal_px: f64, distance_m: f64) -> RasterScene {
    let camera = Camera {
        pos_m: [0.0, -distance_m, 1.0],
        right: [1.0, 0.0, 0.0],
        up: [0.0, 0.0, 1.0],
        forward: [0.0, 1.0, 0.0],
        near_m: 0.05,
        sx: focal_px,
        ox: 0.5 * f64::from(width),
        sy: focal_px,
        oy: 0.5 * f64::from(height),
        width_px: width,
        height_px: height,
    };
    RasterScene {
        camera,
        lights: vec![
            Light {
                to_light: [0.0, -1.0, 0.0],
                ambient: [0.45; 3],
                diffuse: [0.5; 3],
            },
            Light {
                to_light: [-0.19, -0.28, 0.94],
                ambient: [0.0; 3],
                diffuse: [0.35; 3],
            },
        ],
        instances: vec![
            at(
                Shape::Plane { half_m: [7.0, 7.0] },
                [0.0; 3],
                [0.35, 0.36, 0.38],
                Some(9.9),
            ),
            at(
                Shape::Box {
                    half_m: [7.0, 0.05, 3.0],
                },
                [0.0, 7.0, 3.0],
                [0.45, 0.53, 0.62],
                Some(7.7),
            ),
            at(Shape::Mesh(0), [0.0, 0.0, 1.0], [0.9; 3], Some(0.101)),
            at(
                Shape::Mesh(0),
                [0.6, 0.5, 0.7],
                [0.3, 0.3, 0.3],
                Some(0.101),
            ),
        ],
        background: [0; 3],
    }
}
