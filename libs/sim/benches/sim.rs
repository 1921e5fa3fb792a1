//! Foundation figures, every render path in one run: render time per 640×480 frame (one
//! camera) while the performer drifts 1 mm per render (the common case: a still camera, so
//! damage rectangles), and while the camera itself moves 1 mm per render (wind, the cascade:
//! every frame whole); and physics steps per second for 4 drones (performer + 3 observers).
//! `cargo bench -p sim --bench sim`.

use criterion::{Criterion, criterion_group, criterion_main};
use proto::scene::PERFORMER_HOVER_M;
use sim::render::{CameraRenderer, RenderPath};
use sim::world::World;

fn render_one_camera(c: &mut Criterion) {
    let mut group = c.benchmark_group("render_640x480_one_camera_performer_drifting");
    for path in RenderPath::ALL {
        let mut world = World::new(3).expect("scene");
        let mut renderer = CameraRenderer::new(&world, path).expect("renderer");
        let mut k = 0u64;
        group.bench_function(path.as_str(), |b| {
            b.iter(|| {
                k += 1;
                let x = 1e-3 * (k % 200) as f64;
                let p = [x, PERFORMER_HOVER_M[1], PERFORMER_HOVER_M[2]];
                world.set_pose(0, p, [1.0, 0.0, 0.0, 0.0]);
                world.forward_at(k * 10_000_000);
                renderer.render(&mut world, 0).expect("render").len()
            })
        });
    }
    group.finish();
}

fn render_moving_camera(c: &mut Criterion) {
    let mut group = c.benchmark_group("render_640x480_one_camera_moving");
    for path in RenderPath::ALL {
        let mut world = World::new(3).expect("scene");
        let home = proto::scene::Formation::standard(3)
            .expect("formation")
            .placements()[0];
        let mut renderer = CameraRenderer::new(&world, path).expect("renderer");
        let mut k = 0u64;
        group.bench_function(path.as_str(), |b| {
            b.iter(|| {
                k += 1;
                let dz = 1e-3 * (k % 200) as f64;
                let p = home.home_m;
                world.teleport(1, [p[0], p[1], p[2] + dz], home.yaw_rad);
                world.forward_at(k * 10_000_000);
                renderer.render(&mut world, 0).expect("render").len()
            })
        });
    }
    group.finish();
}

fn physics_step_4_drones(c: &mut Criterion) {
    let mut world = World::new(3).expect("scene");
    c.bench_function("physics_step_4_drones", |b| b.iter(|| world.step()));
}

criterion_group!(
    benches,
    render_one_camera,
    render_moving_camera,
    physics_step_4_drones
);
criterion_main!(benches);
