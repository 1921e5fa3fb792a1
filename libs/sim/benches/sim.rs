//! Foundation figures: render time per 640×480 frame (one camera) and physics steps per second
//! for 4 drones (performer + 3 observers). `cargo bench -p sim --bench sim`.

use criterion::{Criterion, criterion_group, criterion_main};
use sim::render::CameraRenderer;
use sim::world::World;

fn render_one_camera(c: &mut Criterion) {
    let mut world = World::new(3).expect("scene");
    let mut renderer = CameraRenderer::new(&world).expect("renderer");
    c.bench_function("render_640x480_one_camera", |b| {
        b.iter(|| renderer.render(&mut world, 0).expect("render").len())
    });
}

fn physics_step_4_drones(c: &mut Criterion) {
    let mut world = World::new(3).expect("scene");
    c.bench_function("physics_step_4_drones", |b| b.iter(|| world.step()));
}

criterion_group!(benches, render_one_camera, physics_step_4_drones);
criterion_main!(benches);
