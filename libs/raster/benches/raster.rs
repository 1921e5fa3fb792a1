//! The renderer alone on the tests' synthetic scene (`tests/support/scene.rs`) at 640×480: a
//! floor, a wall and two 3 200-triangle balls, the near one ≈ 90 px wide, drawn as a damage
//! rectangle around the near ball and as a whole frame. `cargo bench -p raster`. The comparison
//! with MuJoCo's renderer on the real scene is `cargo bench -p sim --bench sim` (every path in
//! one run).

use criterion::{Criterion, criterion_group, criterion_main};
use raster::{MeshLods, Rect, Renderer};

#[path = "../tests/support/scene.rs"]
mod support;

fn bench(c: &mut Criterion) {
    let scene = support::scene(640, 480, 580.0, 1.3);
    let mut renderer = Renderer::new(vec![MeshLods::build(support::ball(40, 0.1))]);
    let mut rgb = vec![0u8; 640 * 480 * 3];
    let damage = Rect {
        x: 270,
        y: 190,
        width: 100,
        height: 100,
    };
    c.bench_function("raster_damage_100x100", |b| {
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
