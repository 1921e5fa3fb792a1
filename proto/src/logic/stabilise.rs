//! Ego-rotation compensation: the receiver's image-plane trajectory as the observer's camera
//! would have seen it had its airframe held its home attitude.
//!
//! An observer hovering in real air tilts to hold its position (the cascade controller leans
//! ≈ 0.5° against a 5 mm estimate error), and its camera is rigidly mounted: the whole image
//! swings with it, ≈ 5 px per 0.5° at this focal length, on strokes of ≈ 70 px. A rotation of a
//! pinhole camera about its centre is a homography of the image whatever the scene (the same
//! map [`crate::rectify`] uses to turn the camera virtually), so the receiver undoes it exactly
//! from its airframe's attitude — what an IMU-aided attitude estimate gives a real drone,
//! the usual ego-motion compensation of event cameras on quadrotors (Falanga, Kleber and
//! Scaramuzza, "Dynamic obstacle avoidance for quadrotors with event cameras", Science Robotics
//! 5(40), 2020, which derotates events with the IMU's rates before detecting moving objects).
//!
//! Translation is not compensated: the airframe's own position is known only as well as its
//! estimate, and a few millimetres at 1.3–2 m move the target by about a pixel. The camera's
//! 4 cm lever arm ahead of the body turns a 0.5° tilt into 0.35 mm, ignored too.

use crate::scene::ObserverCamera;
use crate::segmenter::Sample;

/// How far the airframe has turned from its home attitude: the rotation, in world axes, that
/// takes the home attitude to the current one (row-major 3×3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EgoRotation {
    pub world_from_home: [[f64; 3]; 3],
}

impl EgoRotation {
    /// The rotation from `home` to `now`, both world-from-body unit quaternions (w, x, y, z).
    /// `None` when they are equal to the last bit: the airframe has not turned, and a receiver
    /// that is handed no rotation computes exactly what it did before this module existed.
    pub fn between(home_wxyz: [f64; 4], now_wxyz: [f64; 4]) -> Option<Self> {
        if home_wxyz == now_wxyz {
            return None;
        }
        let now = matrix(now_wxyz);
        let home = matrix(home_wxyz);
        let mut m = [[0.0; 3]; 3];
        for (r, row) in m.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                // now · homeᵀ
                *v = (0..3).map(|k| now[r][k] * home[c][k]).sum();
            }
        }
        Some(Self { world_from_home: m })
    }

    /// The angle turned, radians.
    pub fn angle_rad(&self) -> f64 {
        let m = &self.world_from_home;
        ((m[0][0] + m[1][1] + m[2][2] - 1.0) / 2.0)
            .clamp(-1.0, 1.0)
            .acos()
    }

    fn apply_transposed(&self, v: [f64; 3]) -> [f64; 3] {
        let m = &self.world_from_home;
        [0, 1, 2].map(|c| m[0][c] * v[0] + m[1][c] * v[1] + m[2][c] * v[2])
    }

    fn apply(&self, v: [f64; 3]) -> [f64; 3] {
        let m = &self.world_from_home;
        [0, 1, 2].map(|r| m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2])
    }
}

/// The rotation matrix of a unit quaternion (w, x, y, z), row-major.
pub fn matrix([w, x, y, z]: [f64; 4]) -> [[f64; 3]; 3] {
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

/// Where pixel `p` of `home`'s camera turned by `ego` lands in `home`'s camera; `None` for a
/// ray behind it.
pub fn stabilised_px(home: &ObserverCamera, ego: &EgoRotation, p: [f64; 2]) -> Option<[f64; 2]> {
    let ray_world = ego.apply(home.world_from_camera_dir(ObserverCamera::ray_of_px(p)));
    ObserverCamera::image_px(home.camera_from_world_dir(ray_world))
}

/// Where a world point appears in `home`'s camera turned by `ego` (the inverse of
/// [`stabilised_px`], for tests and for simulating a turned camera's track).
pub fn turned_px(home: &ObserverCamera, ego: &EgoRotation, world_m: [f64; 3]) -> Option<[f64; 2]> {
    let d = [
        world_m[0] - home.world_pos_m[0],
        world_m[1] - home.world_pos_m[1],
        world_m[2] - home.world_pos_m[2],
    ];
    ObserverCamera::image_px(home.camera_from_world_dir(ego.apply_transposed(d)))
}

/// Where a static point seen at pixel `p` by `home`'s camera turned by `from` appears once the
/// camera is turned by `to` (`None`: not turned): the image motion the airframe's own turn
/// causes, an inertial-aided tracker's prediction (Hwangbo, Kim and Kanade, "Inertial-aided KLT
/// feature tracking for a moving camera", IROS 2009). `None` for a ray behind the camera.
pub fn predicted_px(
    home: &ObserverCamera,
    from: Option<&EgoRotation>,
    to: Option<&EgoRotation>,
    p: [f64; 2],
) -> Option<[f64; 2]> {
    let q = match from {
        Some(e) => stabilised_px(home, e, p)?,
        None => p,
    };
    let Some(to) = to else { return Some(q) };
    let ray_world = to.apply_transposed(home.world_from_camera_dir(ObserverCamera::ray_of_px(q)));
    ObserverCamera::image_px(home.camera_from_world_dir(ray_world))
}

/// The sample as `home`'s unturned camera would have given it (a point that cannot be mapped
/// is an unreliable sample without a point).
pub fn stabilised_sample(home: &ObserverCamera, ego: &EgoRotation, sample: Sample) -> Sample {
    sample.mapped(|p| stabilised_px(home, ego, p))
}

/// A unit quaternion (w, x, y, z) turning by `angle_rad` about `axis` (normalised here).
pub fn about(axis: [f64; 3], angle_rad: f64) -> [f64; 4] {
    let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
    let (s, c) = (angle_rad / 2.0).sin_cos();
    [c, s * axis[0] / n, s * axis[1] / n, s * axis[2] / n]
}

/// The Hamilton product `a·b` of two quaternions (w, x, y, z): turn by `b`, then by `a`.
pub fn product(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    let [aw, ax, ay, az] = a;
    let [bw, bx, by, bz] = b;
    [
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{PERFORMER_HOVER_M, Placement};

    #[test]
    fn an_unturned_airframe_gives_no_rotation() {
        let q = about([0.0, 0.0, 1.0], 1.1);
        assert_eq!(EgoRotation::between(q, q), None);
    }

    #[test]
    fn the_rotation_between_attitudes_has_the_turned_angle() {
        let home = about([0.0, 0.0, 1.0], 0.7);
        for (axis, angle) in [([1.0, 0.0, 0.0], 0.01), ([0.3, -1.0, 0.2], 0.05)] {
            let now = product(about(axis, angle), home);
            let ego = EgoRotation::between(home, now).unwrap();
            assert!((ego.angle_rad() - angle).abs() < 1e-9, "{axis:?}");
        }
    }

    #[test]
    fn stabilising_undoes_the_turn_for_every_point_and_viewpoint() {
        for (az, el, dist) in [(0.0, 0.0, 1.3), (35.0, 10.0, 1.8), (-40.0, 25.0, 2.0)] {
            let placement = Placement::viewpoint(az, el, dist);
            let home_cam = placement.camera();
            let home_q = about([0.0, 0.0, 1.0], placement.yaw_rad);
            // A lean of ≈ 1° about a tilted axis and a small yaw.
            let now_q = product(about([0.4, 0.9, 0.2], 0.02), home_q);
            let ego = EgoRotation::between(home_q, now_q).unwrap();
            for (dx, dz) in [(0.0, 0.0), (0.1, 0.0), (-0.1, 0.1), (0.05, -0.1)] {
                let h = PERFORMER_HOVER_M;
                let world = [h[0] + dx, h[1], h[2] + dz];
                let seen = turned_px(&home_cam, &ego, world).unwrap();
                let unturned = home_cam.project_px(world).unwrap();
                // The turn moves the image by pixels ...
                let moved = (seen[0] - unturned[0]).hypot(seen[1] - unturned[1]);
                assert!(moved > 3.0, "az {az}: moved {moved}");
                // ... and stabilising puts every point back.
                let back = stabilised_px(&home_cam, &ego, seen).unwrap();
                assert!((back[0] - unturned[0]).abs() < 1e-6, "az {az}: {back:?}");
                assert!((back[1] - unturned[1]).abs() < 1e-6, "az {az}: {back:?}");
            }
        }
    }

    /// A performer resting at the hover point while the observer's airframe rocks by ±3°
    /// (≈ 20 px in the image, beyond the 15 px anchor): the raw track never rests, the
    /// stabilised one confirms its NULL after the 3 s rest as a still camera's would.
    #[test]
    fn a_rocking_camera_breaks_a_rest_unless_its_turn_is_undone() {
        use crate::rectify::Rectification;
        use crate::segmenter::{Segmenter, SegmenterConfig};
        use crate::token::Token;
        let placement = Placement::viewpoint(15.0, 5.0, 1.4);
        let home_cam = placement.camera();
        let home_q = about([0.0, 0.0, 1.0], placement.yaw_rad);
        let config = SegmenterConfig::rgb().rectified(home_cam, Rectification::Off);
        let run = |undo: bool| {
            let mut seg = Segmenter::new(config).unwrap();
            let mut tokens = Vec::new();
            for k in 0..125u64 {
                let t_ns = (k + 1) * 40_000_000;
                // One rock every 1.2 s about the camera's horizontal axis (pitch).
                let angle = 0.05 * (k as f64 * 0.04 * std::f64::consts::TAU / 1.2).sin();
                let axis = [-placement.yaw_rad.sin(), placement.yaw_rad.cos(), 0.0];
                let now_q = product(about(axis, angle), home_q);
                let ego = EgoRotation::between(home_q, now_q);
                let seen = match &ego {
                    Some(e) => turned_px(&home_cam, e, PERFORMER_HOVER_M).unwrap(),
                    None => home_cam.project_px(PERFORMER_HOVER_M).unwrap(),
                };
                seg.set_ego_rotation(if undo { ego } else { None });
                tokens.extend(seg.push(Sample::tracked(t_ns, seen)).unwrap());
            }
            tokens.iter().map(|t| t.token).collect::<Vec<_>>()
        };
        assert_eq!(run(true), vec![Token::Null]);
        assert!(!run(false).contains(&Token::Null));
    }

    #[test]
    fn a_static_point_is_predicted_where_the_turned_camera_sees_it() {
        let placement = Placement::viewpoint(30.0, 5.0, 1.6);
        let cam = placement.camera();
        let home_q = about([0.0, 0.0, 1.0], placement.yaw_rad);
        let turn = |axis, a| EgoRotation::between(home_q, product(about(axis, a), home_q));
        let (a, b) = (turn([1.0, 0.0, 0.0], 0.02), turn([0.2, 1.0, 0.0], -0.015));
        let h = PERFORMER_HOVER_M;
        for world in [
            h,
            [h[0] + 0.1, h[1], h[2] - 0.05],
            [h[0] - 2.0, h[1] + 6.0, 0.5],
        ] {
            let seen = |e: &Option<EgoRotation>| match e {
                Some(e) => turned_px(&cam, e, world).unwrap(),
                None => cam.project_px(world).unwrap(),
            };
            for (from, to) in [(&a, &b), (&None, &a), (&b, &None), (&None, &None)] {
                let p = predicted_px(&cam, from.as_ref(), to.as_ref(), seen(from)).unwrap();
                let want = seen(to);
                assert!((p[0] - want[0]).abs() < 1e-6 && (p[1] - want[1]).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn a_sample_without_a_point_passes_unchanged() {
        let cam = Placement::viewpoint(10.0, 0.0, 1.5).camera();
        let ego = EgoRotation::between([1.0, 0.0, 0.0, 0.0], about([1.0, 0.0, 0.0], 0.01)).unwrap();
        let s = Sample::lost(9);
        assert_eq!(stabilised_sample(&cam, &ego, s), s);
    }
}
