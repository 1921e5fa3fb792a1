//! Waggle's camera model in ROS terms: the intrinsics of `sensor_msgs/CameraInfo` and the
//! camera's optical frame on its drone (REP 103: x right, y down, z forward).
//!
//! Waggle projects with `proto::scene::ObserverCamera::project_px`: a pinhole of focal
//! [`proto::scene::focal_px`] with the image centre at (W/2, H/2) in coordinates whose origin is
//! the top-left *corner* of the top-left pixel. ROS (and OpenCV) put the origin at that pixel's
//! *centre*, so the principal point is (W/2 − ½, H/2 − ½). The camera sits
//! [`proto::scene::CAMERA_OFFSET_BODY_M`] ahead of the body origin along body x, pitched down by
//! the placement's pitch about body y (MuJoCo's camera in `libs/sim/src/mjcf.rs`).

use proto::scene::{CAMERA_OFFSET_BODY_M, IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX, focal_px};

use crate::messages::{
    CameraInfoMsg, HeaderMsg, QuaternionMsg, RegionOfInterestMsg, TransformStampedMsg, Vector3Msg,
};

/// The camera's intrinsics as a `CameraInfo` (no distortion: `plumb_bob` with zeros).
pub fn camera_info(header: HeaderMsg) -> CameraInfoMsg {
    let f = focal_px();
    let cx = f64::from(IMAGE_WIDTH_PX) / 2.0 - 0.5;
    let cy = f64::from(IMAGE_HEIGHT_PX) / 2.0 - 0.5;
    CameraInfoMsg {
        header,
        height: u32::from(IMAGE_HEIGHT_PX),
        width: u32::from(IMAGE_WIDTH_PX),
        distortion_model: "plumb_bob".into(),
        d: vec![0.0; 5],
        k: [f, 0.0, cx, 0.0, f, cy, 0.0, 0.0, 1.0],
        r: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        p: [f, 0.0, cx, 0.0, 0.0, f, cy, 0.0, 0.0, 0.0, 1.0, 0.0],
        binning_x: 0,
        binning_y: 0,
        roi: RegionOfInterestMsg::default(),
    }
}

/// A rotation matrix (rows) as a unit quaternion (Shepperd's method).
fn quaternion_of(m: [[f64; 3]; 3]) -> QuaternionMsg {
    let trace = m[0][0] + m[1][1] + m[2][2];
    let (x, y, z, w) = if trace > 0.0 {
        let s = (trace + 1.0).sqrt() * 2.0;
        (
            (m[2][1] - m[1][2]) / s,
            (m[0][2] - m[2][0]) / s,
            (m[1][0] - m[0][1]) / s,
            s / 4.0,
        )
    } else if m[0][0] > m[1][1] && m[0][0] > m[2][2] {
        let s = (1.0 + m[0][0] - m[1][1] - m[2][2]).sqrt() * 2.0;
        (
            s / 4.0,
            (m[0][1] + m[1][0]) / s,
            (m[0][2] + m[2][0]) / s,
            (m[2][1] - m[1][2]) / s,
        )
    } else if m[1][1] > m[2][2] {
        let s = (1.0 + m[1][1] - m[0][0] - m[2][2]).sqrt() * 2.0;
        (
            (m[0][1] + m[1][0]) / s,
            s / 4.0,
            (m[1][2] + m[2][1]) / s,
            (m[0][2] - m[2][0]) / s,
        )
    } else {
        let s = (1.0 + m[2][2] - m[0][0] - m[1][1]).sqrt() * 2.0;
        (
            (m[0][2] + m[2][0]) / s,
            (m[1][2] + m[2][1]) / s,
            s / 4.0,
            (m[1][0] - m[0][1]) / s,
        )
    };
    // One sign for a rotation (w ≥ 0), so equal rotations give equal bytes.
    let sign = if w < 0.0 { -1.0 } else { 1.0 };
    QuaternionMsg {
        x: sign * x,
        y: sign * y,
        z: sign * z,
        w: sign * w,
    }
}

/// The optical axes (x right, y down, z forward) of a camera pitched down by `pitch_rad`, in
/// body axes (x forward, y left, z up): the columns of the rotation body ← optical.
pub fn optical_axes_in_body(pitch_rad: f64) -> [[f64; 3]; 3] {
    let (s, c) = pitch_rad.sin_cos();
    // Forward tipped down by the pitch; left stays body y; up tipped back.
    let forward = [c, 0.0, -s];
    let up = [s, 0.0, c];
    let right = [0.0, -1.0, 0.0];
    let down = [-up[0], -up[1], -up[2]];
    // Rows of the matrix whose columns are right, down, forward.
    [
        [right[0], down[0], forward[0]],
        [right[1], down[1], forward[1]],
        [right[2], down[2], forward[2]],
    ]
}

/// The static transform from observer `observer`'s body frame to its camera's optical frame.
pub fn camera_mount(
    header: HeaderMsg,
    child_frame_id: String,
    pitch_rad: f64,
) -> TransformStampedMsg {
    TransformStampedMsg {
        header,
        child_frame_id,
        translation: Vector3Msg {
            x: CAMERA_OFFSET_BODY_M,
            y: 0.0,
            z: 0.0,
        },
        rotation: quaternion_of(optical_axes_in_body(pitch_rad)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::scene::{Formation, MAX_OBSERVERS, PERFORMER_HOVER_M};

    /// Rotates `v` by the unit quaternion `q`.
    fn rotate(q: &QuaternionMsg, v: [f64; 3]) -> [f64; 3] {
        let m = proto::stabilise::matrix([q.w, q.x, q.y, q.z]);
        std::array::from_fn(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2])
    }

    #[test]
    fn a_level_camera_has_rep_103s_optical_rotation() {
        let q = camera_mount(HeaderMsg::default(), "c".into(), 0.0).rotation;
        for (got, want) in [(q.x, -0.5), (q.y, 0.5), (q.z, -0.5), (q.w, 0.5)] {
            assert!((got - want).abs() < 1e-15, "{q:?}");
        }
    }

    /// The TF chain world → body (level, yawed, at home) → optical, then the CameraInfo's K,
    /// projects points exactly where Waggle's own camera model does (less the half pixel).
    #[test]
    fn tf_and_camera_info_project_like_waggles_camera_model() {
        let info = camera_info(HeaderMsg::default());
        let k = info.k;
        for n in 1..=MAX_OBSERVERS {
            for p in Formation::standard(n).unwrap().placements() {
                let mount = camera_mount(HeaderMsg::default(), "c".into(), p.pitch_rad);
                let (s, c) = p.yaw_rad.sin_cos();
                let body_from_world =
                    |v: [f64; 3]| [c * v[0] + s * v[1], -s * v[0] + c * v[1], v[2]];
                let cam = p.camera();
                for point in [PERFORMER_HOVER_M, [0.1, 0.05, 1.45], [-0.2, 0.1, 1.2]] {
                    let rel = [
                        point[0] - p.home_m[0],
                        point[1] - p.home_m[1],
                        point[2] - p.home_m[2],
                    ];
                    let b = body_from_world(rel);
                    let b = [b[0] - mount.translation.x, b[1], b[2]];
                    // optical ← body is the inverse (conjugate) rotation.
                    let inv = QuaternionMsg {
                        x: -mount.rotation.x,
                        y: -mount.rotation.y,
                        z: -mount.rotation.z,
                        w: mount.rotation.w,
                    };
                    let o = rotate(&inv, b);
                    let u = k[0] * o[0] / o[2] + k[2];
                    let v = k[4] * o[1] / o[2] + k[5];
                    let want = cam.project_px(point).unwrap();
                    assert!(
                        (u - (want[0] - 0.5)).abs() < 1e-9 && (v - (want[1] - 0.5)).abs() < 1e-9,
                        "N={n} {point:?}: ({u}, {v}) vs {want:?}"
                    );
                }
            }
        }
    }
}
