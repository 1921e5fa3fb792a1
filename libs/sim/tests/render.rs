//! Rendering: the performer appears where the camera model says, moves as predicted, and
//! rendering is deterministic.

use proto::scene::{IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX, ObserverCamera, PERFORMER_HOVER_M};
use sim::render::{CameraRenderer, RenderPath};
use sim::world::World;

const W: usize = IMAGE_WIDTH_PX as usize;
const H: usize = IMAGE_HEIGHT_PX as usize;

/// Centroid and pixel count of the pixels that differ between two renders.
fn diff_blob(a: &[u8], b: &[u8]) -> Option<([f64; 2], usize)> {
    let (mut sx, mut sy, mut n) = (0.0, 0.0, 0usize);
    for y in 0..H {
        for x in 0..W {
            let i = (y * W + x) * 3;
            let d: i32 = (0..3)
                .map(|c| (i32::from(a[i + c]) - i32::from(b[i + c])).abs())
                .sum();
            if d > 30 {
                sx += x as f64 + 0.5;
                sy += y as f64 + 0.5;
                n += 1;
            }
        }
    }
    (n > 0).then(|| ([sx / n as f64, sy / n as f64], n))
}

/// Observer cameras skip drawing other observers' airframes; that is harmless only while no
/// observer is in another's view at home. For every group size, drawing them changes no pixel.
#[test]
fn no_observer_sees_another_at_home_in_any_formation() {
    for n in 1..=proto::scene::MAX_OBSERVERS {
        let mut world = World::new(n).expect("scene");
        let mut renderer = CameraRenderer::new(&world, RenderPath::Full).expect("EGL renderer");
        for i in 0..n {
            let hidden = renderer.render(&mut world, i).unwrap().to_vec();
            renderer.show_observers(true);
            let shown = renderer.render(&mut world, i).unwrap().to_vec();
            renderer.show_observers(false);
            assert!(
                hidden == shown,
                "N = {n}: another airframe is in O{}'s view",
                i + 1
            );
        }
    }
}

#[test]
fn performer_is_a_compact_blob_that_moves_as_the_camera_model_predicts() {
    for n in [3, 8] {
        performer_blob_moves_as_predicted(n);
    }
}

fn performer_blob_moves_as_predicted(n: usize) {
    let mut world = World::new(n).expect("scene");
    let mut renderer = CameraRenderer::new(&world, RenderPath::Full).expect("EGL renderer");

    let mut at_hover = Vec::new();
    for i in 0..n {
        let first = renderer.render(&mut world, i).unwrap().to_vec();
        let again = renderer.render(&mut world, i).unwrap().to_vec();
        assert!(
            first == again,
            "observer {i}: two renders of the same state differ"
        );
        renderer.show_observers(true);
        let with_observers = renderer.render(&mut world, i).unwrap().to_vec();
        renderer.show_observers(false);
        assert!(
            first == with_observers,
            "observer {i}: another observer's airframe is in view"
        );
        at_hover.push(first);
    }
    // Without the performer (parked far below the floor) the difference is exactly the performer.
    world.teleport(0, [0.0, 0.0, -20.0], 0.0);
    let mut empty = Vec::new();
    for i in 0..n {
        empty.push(renderer.render(&mut world, i).unwrap().to_vec());
    }
    world.teleport(
        0,
        [
            PERFORMER_HOVER_M[0] + 0.1,
            PERFORMER_HOVER_M[1],
            PERFORMER_HOVER_M[2],
        ],
        0.0,
    );
    for i in 0..n {
        let moved = renderer.render(&mut world, i).unwrap().to_vec();
        let (c0, px) = diff_blob(&at_hover[i], &empty[i]).expect("performer visible");
        assert!(
            px > 60 && px < 5000,
            "observer {i}: blob of {px} px is not compact"
        );
        assert!(
            (c0[0] - 320.0).abs() < 40.0 && (c0[1] - 240.0).abs() < 40.0,
            "observer {i}: performer at {c0:?}, not near the image centre"
        );
        let (c1, _) = diff_blob(&moved, &empty[i]).expect("performer visible after move");
        let cam = ObserverCamera::at_home(i, n);
        let p0 = cam.project_px(PERFORMER_HOVER_M).unwrap();
        let p1 = cam.project_px([0.1, 0.0, 1.3]).unwrap();
        let predicted = p1[0] - p0[0];
        let measured = c1[0] - c0[0];
        assert!(
            predicted > 0.0 && measured > 0.0,
            "observer {i}: wrong direction {measured} vs {predicted}"
        );
        assert!(
            (measured - predicted).abs() <= 0.2 * predicted,
            "observer {i}: moved {measured:.1} px, camera model predicts {predicted:.1} px"
        );
        // Level cameras see no vertical motion; pitched ones see the perspective tilt the
        // camera model predicts.
        let predicted_dy = p1[1] - p0[1];
        assert!(
            (c1[1] - c0[1] - predicted_dy).abs() < 3.0,
            "N = {n} observer {i}: vertical drift {c0:?} -> {c1:?}, model {predicted_dy:.1} px"
        );
    }
}
