//! The renderer against its own definitions, on the synthetic scene of `support/scene.rs`: a rectangle equals the same
//! pixels of a whole frame; an instance is culled exactly when its projected sphere misses the
//! rectangle, and culling changes no pixel; the level of detail follows its rule; bad meshes
//! and bad calls are refused naming what is wrong.

use raster::render::RasterError;
use raster::{Mesh, MeshError, MeshLods, RasterScene, Rect, Renderer, Shape};

const W: u16 = 160;
const H: u16 = 120;

#[path = "support/scene.rs"]
mod support;
use support::{ball, scene as scene_of};

fn scene() -> RasterScene {
    scene_of(W, H, 150.0, 2.0)
}

fn renderer() -> Renderer {
    Renderer::new(vec![MeshLods::build(ball(40, 0.1))])
}

#[test]
fn a_rectangle_equals_the_same_pixels_of_a_whole_frame() {
    let s = scene();
    let mut whole = vec![0u8; usize::from(W) * usize::from(H) * 3];
    renderer().render(&s, Rect::full(W, H), &mut whole).unwrap();
    for rect in [
        Rect {
            x: 60,
            y: 40,
            width: 40,
            height: 40,
        },
        Rect {
            x: 0,
            y: 0,
            width: 1,
            height: 1,
        },
        Rect {
            x: 100,
            y: 70,
            width: 60,
            height: 50,
        },
        Rect {
            x: 77,
            y: 3,
            width: 9,
            height: 117,
        },
    ] {
        let mut part = vec![7u8; whole.len()];
        let stats = renderer().render(&s, rect, &mut part).unwrap();
        for y in 0..usize::from(H) {
            for x in 0..usize::from(W) {
                let o = (y * usize::from(W) + x) * 3;
                let inside = (usize::from(rect.x)..usize::from(rect.x + rect.width)).contains(&x)
                    && (usize::from(rect.y)..usize::from(rect.y + rect.height)).contains(&y);
                if inside {
                    assert_eq!(part[o..o + 3], whole[o..o + 3], "{rect:?} at ({x}, {y})");
                } else {
                    assert_eq!(
                        part[o..o + 3],
                        [7; 3],
                        "{rect:?} wrote outside at ({x}, {y})"
                    );
                }
            }
        }
        assert_eq!(
            stats.instances_drawn + stats.instances_culled,
            s.instances.len() as u64
        );
    }
}

#[test]
fn an_instance_is_culled_exactly_when_its_sphere_misses_the_rectangle() {
    let s = scene();
    let cam = s.camera;
    for inst in &s.instances[2..] {
        let b = cam.sphere_box(inst.pos_m, inst.bound_m.unwrap()).unwrap();
        // A rectangle well clear of the sphere's box culls it, one over its centre does not.
        let clear = Rect {
            x: (b[2].ceil() as u16 + 3).min(W - 2),
            y: 0,
            width: 1,
            height: 1,
        };
        let only = RasterScene {
            instances: vec![*inst],
            ..s.clone()
        };
        let mut rgb = vec![0u8; usize::from(W) * usize::from(H) * 3];
        let stats = renderer().render(&only, clear, &mut rgb).unwrap();
        assert_eq!((stats.instances_culled, stats.triangles_submitted), (1, 0));
        let centre = Rect {
            x: ((b[0] + b[2]) / 2.0) as u16,
            y: ((b[1] + b[3]) / 2.0) as u16,
            width: 1,
            height: 1,
        };
        let stats = renderer().render(&only, centre, &mut rgb).unwrap();
        assert_eq!(stats.instances_culled, 0);
        assert!(stats.pixels_written > 0);
    }
}

#[test]
fn the_level_of_detail_follows_its_rule_and_large_bodies_get_the_full_mesh() {
    let lods = MeshLods::build(ball(60, 0.1));
    let levels = lods.levels();
    assert!(levels.len() >= 3, "only {} levels", levels.len());
    for pair in levels.windows(2) {
        assert!(pair[1].triangles().len() * 10 <= pair[0].triangles().len() * 9);
    }
    let mut last = lods.levels().len();
    for r in [0.5, 2.0, 5.0, 10.0, 20.0, 40.0, 80.0, 200.0] {
        let k = lods.level_for(r);
        assert!(k <= last, "a larger body got a coarser level");
        last = k;
        let disc = std::f64::consts::PI * r * r;
        let n = levels[k].triangles().len() as f64;
        assert!(
            n * raster::mesh::PX_PER_TRIANGLE >= disc || k == 0,
            "radius {r}: level {k} has {n} triangles for {disc:.0} px"
        );
        if k + 1 < levels.len() {
            assert!(
                levels[k + 1].triangles().len() as f64 * raster::mesh::PX_PER_TRIANGLE < disc,
                "radius {r}: level {} would have done",
                k + 1
            );
        }
    }
    assert_eq!(lods.level_for(200.0), 0);
}

#[test]
fn bad_meshes_and_bad_calls_are_refused_naming_what_is_wrong() {
    let p = vec![[0.0f32; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let n = vec![[[0.0f32, 0.0, 1.0]; 3]];
    let err = Mesh::new("cf2x_pcb.stl", p.clone(), vec![[0, 1, 3]], n.clone()).unwrap_err();
    assert!(err.to_string().contains("cf2x_pcb.stl"), "{err}");
    assert!(matches!(err, MeshError::BadIndex { vertex: 3, .. }));
    let mut nan = p.clone();
    nan[1][0] = f32::NAN;
    assert!(matches!(
        Mesh::new("m", nan, vec![[0, 1, 2]], n.clone()),
        Err(MeshError::NotFinite { .. })
    ));
    assert!(matches!(
        Mesh::new("m", p.clone(), vec![], vec![]),
        Err(MeshError::Empty { .. })
    ));
    assert!(matches!(
        Mesh::new("m", p, vec![[0, 1, 2]], vec![]),
        Err(MeshError::NormalCount { .. })
    ));
    let s = scene();
    let mut small = vec![0u8; 10];
    assert!(matches!(
        renderer().render(&s, Rect::full(W, H), &mut small),
        Err(RasterError::FrameSize { .. })
    ));
    let mut rgb = vec![0u8; usize::from(W) * usize::from(H) * 3];
    let outside = Rect {
        x: 150,
        y: 0,
        width: 20,
        height: 1,
    };
    assert!(matches!(
        renderer().render(&s, outside, &mut rgb),
        Err(RasterError::Rect { .. })
    ));
    let mut no_mesh = s.clone();
    no_mesh.instances[2].shape = Shape::Mesh(9);
    assert!(matches!(
        renderer().render(&no_mesh, Rect::full(W, H), &mut rgb),
        Err(RasterError::NoMesh { mesh: 9, .. })
    ));
}

#[test]
fn frames_are_the_same_bytes_on_every_run_and_thread() {
    let s = scene();
    let draw = || {
        let mut rgb = vec![0u8; usize::from(W) * usize::from(H) * 3];
        renderer().render(&s, Rect::full(W, H), &mut rgb).unwrap();
        rgb
    };
    let once = draw();
    let (a, b) = std::thread::scope(|t| {
        let a = t.spawn(draw);
        let b = t.spawn(draw);
        (a.join().unwrap(), b.join().unwrap())
    });
    assert!(a == once && b == once);
    // The frame is not trivial: floor, wall, both balls and the background all show.
    let mut colours: Vec<[u8; 3]> = once.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
    colours.sort_unstable();
    colours.dedup();
    assert!(colours.len() > 20, "only {} colours", colours.len());
}
