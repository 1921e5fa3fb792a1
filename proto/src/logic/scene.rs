//! Shared scene geometry: performer hover point, task sites, observer homes and camera model.
//!
//! World frame: z up, metres. Observers sit on an arc of radius [`ARC_RADIUS_M`] around the
//! performer, on the −y side (towards the sites), all at the hover altitude and facing the
//! performer. O1 is nearest site A, the last observer nearest site B, which reproduces the
//! paper's allocation (O1, O2 → A and O3 → B in round 1 of the nominal case).

/// Performer hover point.
pub const PERFORMER_HOVER_M: [f64; 3] = [0.0, 0.0, 1.3];
/// Site A (payload site id 1).
pub const SITE_A_M: [f64; 3] = [-1.65, -1.65, 1.3];
/// Site B (payload site id 2).
pub const SITE_B_M: [f64; 3] = [1.65, -1.65, 1.3];
/// Radius of the observer arc around the performer.
pub const ARC_RADIUS_M: f64 = 1.3;
/// Largest supported observer count.
pub const MAX_OBSERVERS: usize = 8;

/// Camera image width in pixels.
pub const IMAGE_WIDTH_PX: u16 = 640;
/// Camera image height in pixels.
pub const IMAGE_HEIGHT_PX: u16 = 480;
/// Vertical field of view: 45° gives f ≈ 579 px, so a 0.2 m excursion at 1.3 m spans ≈ 89 px.
pub const CAMERA_FOVY_DEG: f64 = 45.0;
/// Camera position in the observer body frame (ahead of the airframe, so it does not see itself).
pub const CAMERA_OFFSET_BODY_M: f64 = 0.04;

/// Canonical observer name for 0-based index `i`: `O1`, `O2`, ….
pub fn observer_name(i: usize) -> String {
    format!("O{}", i + 1)
}

/// Angle on the arc (radians, from +x, counter-clockwise) of observer `i` of `n`.
///
/// Observers are spread symmetrically about −y (270°), 40° apart for up to four observers and
/// over 160° beyond that, so no observer appears in another's field of view.
pub fn observer_arc_angle_rad(i: usize, n: usize) -> f64 {
    assert!(n >= 1 && i < n, "observer index {i} out of 0..{n}");
    let step_deg = if n <= 4 { 40.0 } else { 160.0 / (n - 1) as f64 };
    let offset = i as f64 - (n - 1) as f64 / 2.0;
    (270.0 + offset * step_deg).to_radians()
}

/// Home position of observer `i` of `n`.
pub fn observer_home_m(i: usize, n: usize) -> [f64; 3] {
    let a = observer_arc_angle_rad(i, n);
    [
        PERFORMER_HOVER_M[0] + ARC_RADIUS_M * a.cos(),
        PERFORMER_HOVER_M[1] + ARC_RADIUS_M * a.sin(),
        PERFORMER_HOVER_M[2],
    ]
}

/// Yaw (radians) that points an observer at `home` towards the performer hover point.
pub fn observer_home_yaw_rad(home: [f64; 3]) -> f64 {
    (PERFORMER_HOVER_M[1] - home[1]).atan2(PERFORMER_HOVER_M[0] - home[0])
}

/// Focal length in pixels for the shared camera model.
pub fn focal_px() -> f64 {
    f64::from(IMAGE_HEIGHT_PX) / 2.0 / (CAMERA_FOVY_DEG.to_radians() / 2.0).tan()
}

/// A level pinhole camera: position and yaw in the world, looking along its body +x axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevelCamera {
    pub world_pos_m: [f64; 3],
    pub yaw_rad: f64,
}

impl LevelCamera {
    /// The camera of observer `i` of `n` while it is at home.
    pub fn at_home(i: usize, n: usize) -> Self {
        let home = observer_home_m(i, n);
        let yaw = observer_home_yaw_rad(home);
        Self {
            world_pos_m: [
                home[0] + CAMERA_OFFSET_BODY_M * yaw.cos(),
                home[1] + CAMERA_OFFSET_BODY_M * yaw.sin(),
                home[2],
            ],
            yaw_rad: yaw,
        }
    }

    /// Projects a world point into pixel coordinates (x right, y down, origin top-left corner
    /// of the top-left pixel). Returns `None` for points behind the camera.
    pub fn project_px(&self, world_m: [f64; 3]) -> Option<[f64; 2]> {
        let d = [
            world_m[0] - self.world_pos_m[0],
            world_m[1] - self.world_pos_m[1],
            world_m[2] - self.world_pos_m[2],
        ];
        let (s, c) = self.yaw_rad.sin_cos();
        let forward = c * d[0] + s * d[1];
        let left = -s * d[0] + c * d[1];
        let up = d[2];
        if forward <= 1e-9 {
            return None;
        }
        let f = focal_px();
        Some([
            f64::from(IMAGE_WIDTH_PX) / 2.0 - f * left / forward,
            f64::from(IMAGE_HEIGHT_PX) / 2.0 - f * up / forward,
        ])
    }
}

/// Euclidean distance between two world points, metres.
pub fn distance_m(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nominal_arc_puts_o1_o2_nearer_a_and_o3_nearer_b() {
        let h: Vec<_> = (0..3).map(|i| observer_home_m(i, 3)).collect();
        for home in &h {
            assert!((distance_m(*home, PERFORMER_HOVER_M) - ARC_RADIUS_M).abs() < 1e-12);
        }
        assert!(distance_m(h[0], SITE_A_M) < distance_m(h[1], SITE_A_M));
        assert!(distance_m(h[1], SITE_A_M) < distance_m(h[2], SITE_A_M));
        assert!(distance_m(h[2], SITE_B_M) < distance_m(h[1], SITE_B_M));
        assert!(distance_m(h[2], SITE_B_M) < distance_m(h[0], SITE_B_M));
    }

    #[test]
    fn performer_projects_to_image_centre_and_excursion_spans_80_px() {
        for n in 1..=MAX_OBSERVERS {
            for i in 0..n {
                let cam = LevelCamera::at_home(i, n);
                let p = cam.project_px(PERFORMER_HOVER_M).expect("in front");
                assert!(
                    (p[0] - 320.0).abs() < 1e-9 && (p[1] - 240.0).abs() < 1e-9,
                    "{p:?}"
                );
                let up = [0.0, 0.0, 1.5];
                let q = cam.project_px(up).expect("in front");
                assert!(p[1] - q[1] >= 80.0, "0.2 m spans {} px", p[1] - q[1]);
            }
        }
    }

    #[test]
    fn world_x_moves_right_in_every_view() {
        for i in 0..3 {
            let cam = LevelCamera::at_home(i, 3);
            let p = cam.project_px(PERFORMER_HOVER_M).unwrap();
            let q = cam.project_px([0.1, 0.0, 1.3]).unwrap();
            assert!(q[0] > p[0] + 20.0, "observer {i}: {p:?} -> {q:?}");
        }
    }
}
