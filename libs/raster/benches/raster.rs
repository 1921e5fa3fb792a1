//! The renderer alone on a synthetic scene: a floor, a wall and a 4 000-triangle sphere mesh
//! ≈ 48 px wide, as a damage rectangle around the mesh and as a whole 640×480 frame.
//! `cargo bench -p raster`. The comparison with MuJoCo's renderer on the real scene is
//! `cargo bench -p sim --bench sim` (both paths in one run).

use criterion::{Criterion, criterion_group, criterion_main};
use raster::{Camera, Instance, Light, Mesh, MeshLods, RasterScene, Rect, Renderer, Shape};

fn sphere(n: usize) -> Mesh {
    let mut p = Vec::new();
    for i in 0..=n {
        for j in 0..=n {
            let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
            // A lat-long grid; only the bench's geometry, so trigonometry is fine here.
            let (th, ph) = (std::f64::consts::PI * u, 2.0 * std::f64::consts::PI * v);
            p.push([
                (th.sin() * ph.cos()) as f32,
                (th.sin() * ph.sin()) as f32,
                th.cos() as f32,
            ]);
        }
    }
    let mut t = Vec::new();
    let id = |i: usize, j: usize| (i * (n + 1) + j) as u32;
    for i in 0..n {
        for j in 0..n {
            t.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            t.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    let normals = t
        .iter()
        .map(|tri: &[u32; 3]| tri.map(|v| p[v as usize]))
        .collect();
    Mesh::new(
        "sphere",
        p.iter().map(|q| q.map(|c| c * 0.05)).collect(),
        t,
        normals,
    )
    .unwrap()
}

fn scene() -> RasterScene {
    let camera = Camera {
        pos_m: [0.0, -1.3, 1.0],
        right: [1.0, 0.0, 0.0],
        up: [0.0, 0.0, 1.0],
        forward: [0.0, 1.0, 0.0],
        near_m: 0.05,
        sx: 580.0,
        ox: 320.0,
        sy: 580.0,
        oy: 240.0,
        width_px: 640,
        height_px: 480,
    };
    let flat = |shape, pos_m, rgb| Instance {
        shape,
        pos_m,
        rot: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        rgb,
        emission: 0.0,
        bound_m: None,
    };
    RasterScene {
        camera,
        lights: vec![Light {
            to_light: [0.0, -0.6, 0.8],
            ambient: [0.45; 3],
            diffuse: [0.5; 3],
        }],
        instances: vec![
            flat(
                Shape::Plane { half_m: [7.0, 7.0] },
                [0.0; 3],
                [0.35, 0.36, 0.38],
            ),
            flat(
                Shape::Box {
                    half_m: [7.0, 0.05, 3.0],
                },
                [0.0, 7.0, 3.0],
                [0.45, 0.53, 0.62],
            ),
            Instance {
                bound_m: Some(0.051),
                ..flat(Shape::Mesh(0), [0.0, 0.0, 1.0], [0.9; 3])
            },
        ],
        background: [0; 3],
    }
}

fn bench(c: &mut Criterion) {
    let scene = scene();
    let mut renderer = Renderer::new(vec![MeshLods::build(sphere(45))]);
    let mut rgb = vec![0u8; 640 * 480 * 3];
    let damage = Rect {
        x: 280,
        y: 200,
        width: 80,
        height: 80,
    };
    c.bench_function("raster_damage_80x80", |b| {
        b.iter(|| renderer.render(&scene, damage, &mut rgb).unwrap())
    });
    c.bench_function("raster_full_640x480", |b| {
        b.iter(|| {
            renderer
                .render(&scene, Rect::full(640, 480), &mut rgb)
                .unwrap()
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
