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

/// Viewing-cone half-angle of the group formation (N ≥ 4): observers are spread over
/// ±[`GROUP_HALF_SPAN_DEG`] of azimuth around the gesture plane's normal (−y).
pub const GROUP_HALF_SPAN_DEG: f64 = 35.0;
/// Height of the formation's upper row above the hover altitude (N ≥ 4, odd indices).
///
/// With N = 8 neighbours on the arc are 10° (0.23 m) apart horizontally; the rise puts them
/// 0.50 m apart in space while every observer on the same row stays ≥ 0.45 m from the next.
pub const UPPER_ROW_RISE_M: f64 = 0.45;

/// Angle on the arc (radians, from +x, counter-clockwise) of observer `i` of `n`.
///
/// N ≤ 3 is the paper's arc: 40° apart, symmetric about −y (270°). Larger groups are spread
/// evenly over ±[`GROUP_HALF_SPAN_DEG`], alternating between the hover altitude (O1, O3, …) and
/// an upper row (O2, O4, …), so every observer views the gesture plane within 40° of its normal
/// and no observer has another in its field of view (see [`Formation::check`]).
pub fn observer_arc_angle_rad(i: usize, n: usize) -> f64 {
    assert!(n >= 1 && i < n, "observer index {i} out of 0..{n}");
    let step_deg = if n <= 3 {
        40.0
    } else {
        2.0 * GROUP_HALF_SPAN_DEG / (n - 1) as f64
    };
    let offset = i as f64 - (n - 1) as f64 / 2.0;
    (270.0 + offset * step_deg).to_radians()
}

/// Home position of observer `i` of `n` in the built-in formation.
pub fn observer_home_m(i: usize, n: usize) -> [f64; 3] {
    let a = observer_arc_angle_rad(i, n);
    let rise_m = if n > 3 && i % 2 == 1 {
        UPPER_ROW_RISE_M
    } else {
        0.0
    };
    [
        PERFORMER_HOVER_M[0] + ARC_RADIUS_M * a.cos(),
        PERFORMER_HOVER_M[1] + ARC_RADIUS_M * a.sin(),
        PERFORMER_HOVER_M[2] + rise_m,
    ]
}

/// Yaw (radians) that points an observer at `home` towards the performer hover point.
pub fn observer_home_yaw_rad(home: [f64; 3]) -> f64 {
    (PERFORMER_HOVER_M[1] - home[1]).atan2(PERFORMER_HOVER_M[0] - home[0])
}

/// Camera pitch (radians, positive looking down) that aims the camera of an observer at
/// `home` (mounted [`CAMERA_OFFSET_BODY_M`] ahead of the body) at the performer's hover point;
/// exactly 0 at the hover altitude.
pub fn observer_home_pitch_rad(home: [f64; 3]) -> f64 {
    let horizontal_m = (PERFORMER_HOVER_M[0] - home[0]).hypot(PERFORMER_HOVER_M[1] - home[1]);
    (home[2] - PERFORMER_HOVER_M[2]).atan2(horizontal_m - CAMERA_OFFSET_BODY_M)
}

/// Where one observer hovers when at home and how its camera is mounted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    pub home_m: [f64; 3],
    pub yaw_rad: f64,
    /// Camera pitch below the horizon (the airframe itself stays level).
    pub pitch_rad: f64,
}

impl Placement {
    /// An observer at `home_m`, facing and aiming its camera at the performer's hover point.
    pub fn aimed_from(home_m: [f64; 3]) -> Self {
        Self {
            home_m,
            yaw_rad: observer_home_yaw_rad(home_m),
            pitch_rad: observer_home_pitch_rad(home_m),
        }
    }

    /// An observer `distance_m` from the hover point, `azimuth_deg` from the gesture plane's
    /// normal (positive towards +x) and `elevation_deg` above the hover altitude, aimed at it.
    pub fn viewpoint(azimuth_deg: f64, elevation_deg: f64, distance_m: f64) -> Self {
        let (az, el) = (azimuth_deg.to_radians(), elevation_deg.to_radians());
        let h = PERFORMER_HOVER_M;
        Self::aimed_from([
            h[0] + distance_m * el.cos() * az.sin(),
            h[1] - distance_m * el.cos() * az.cos(),
            h[2] + distance_m * el.sin(),
        ])
    }

    /// This observer's camera while it is at home.
    pub fn camera(&self) -> ObserverCamera {
        ObserverCamera {
            world_pos_m: [
                self.home_m[0] + CAMERA_OFFSET_BODY_M * self.yaw_rad.cos(),
                self.home_m[1] + CAMERA_OFFSET_BODY_M * self.yaw_rad.sin(),
                self.home_m[2],
            ],
            yaw_rad: self.yaw_rad,
            pitch_rad: self.pitch_rad,
        }
    }

    /// Distance from home to the performer's hover point.
    pub fn distance_m(&self) -> f64 {
        distance_m(self.home_m, PERFORMER_HOVER_M)
    }

    /// Angle between the line of sight (hover point → home) and the gesture plane's normal
    /// (−y): 0 is head-on; the symbols' horizontal strokes shrink roughly with its cosine.
    pub fn viewing_angle_rad(&self) -> f64 {
        let d = self.distance_m();
        if d == 0.0 {
            return 0.0;
        }
        ((PERFORMER_HOVER_M[1] - self.home_m[1]) / d)
            .clamp(-1.0, 1.0)
            .acos()
    }
}

/// Why a formation is unusable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FormationError {
    #[error("observer count {0} outside 1..={MAX_OBSERVERS}")]
    Count(usize),
    #[error("{observer}: home {home_m:?} is not finite")]
    NonFinite { observer: String, home_m: [f64; 3] },
}

/// The observers' placements, O1 first.
#[derive(Debug, Clone, PartialEq)]
pub struct Formation {
    placements: Vec<Placement>,
}

/// Collision-sphere radius of one drone body, m (the Crazyflie 2 estimate of drone-models).
pub const BODY_RADIUS_M: f64 = 0.07;
/// Least distance between two observers' body centres at home, m.
pub const HOME_CLEARANCE_M: f64 = 0.35;
/// Largest angle between any observer's line of sight and the gesture plane's normal in the
/// built-in formation.
pub const VIEWING_CONE_HALF_ANGLE_DEG: f64 = 40.0;
/// Radius around the hover point that the performer's gestures stay inside, m (symbols reach
/// ≈ ±0.175 m, plus the airframe).
pub const GESTURE_RADIUS_M: f64 = 0.25;

impl Formation {
    /// The built-in formation for `n` observers ([`observer_home_m`]).
    pub fn standard(n: usize) -> Result<Self, FormationError> {
        if !(1..=MAX_OBSERVERS).contains(&n) {
            return Err(FormationError::Count(n));
        }
        Ok(Self {
            placements: (0..n)
                .map(|i| Placement::aimed_from(observer_home_m(i, n)))
                .collect(),
        })
    }

    /// Any placements (a measurement rig: e.g. one observer per viewing angle).
    pub fn custom(placements: Vec<Placement>) -> Result<Self, FormationError> {
        if !(1..=MAX_OBSERVERS).contains(&placements.len()) {
            return Err(FormationError::Count(placements.len()));
        }
        for (i, p) in placements.iter().enumerate() {
            let finite = p.home_m.iter().all(|v| v.is_finite())
                && p.yaw_rad.is_finite()
                && p.pitch_rad.is_finite();
            if !finite {
                return Err(FormationError::NonFinite {
                    observer: observer_name(i),
                    home_m: p.home_m,
                });
            }
        }
        Ok(Self { placements })
    }

    pub fn len(&self) -> usize {
        self.placements.len()
    }

    pub fn is_empty(&self) -> bool {
        self.placements.is_empty()
    }

    pub fn placements(&self) -> &[Placement] {
        &self.placements
    }

    /// Placement of observer `i` (0-based).
    pub fn placement(&self, i: usize) -> Option<&Placement> {
        self.placements.get(i)
    }

    /// Every violation of the formation rules, as readable sentences (empty: the formation is
    /// usable): body clearance between homes, the viewing cone, nobody between a camera and
    /// the performer's gesture volume, and nobody inside another's field of view (which is
    /// what lets observer cameras skip drawing other observers).
    pub fn check(&self, cone_half_angle_deg: f64) -> Vec<String> {
        let mut problems = Vec::new();
        let n = self.placements.len();
        for (i, a) in self.placements.iter().enumerate() {
            let name = observer_name(i);
            let angle_deg = a.viewing_angle_rad().to_degrees();
            if angle_deg > cone_half_angle_deg + 1e-9 {
                problems.push(format!(
                    "{name} views the gesture plane at {angle_deg:.1}° > {cone_half_angle_deg}°"
                ));
            }
            let cam = a.camera();
            if !cam.sees_sphere(PERFORMER_HOVER_M, GESTURE_RADIUS_M) {
                problems.push(format!("{name}: the gesture volume leaves the image"));
            }
            for j in (0..n).filter(|&j| j != i) {
                let b = &self.placements[j];
                let other = observer_name(j);
                let d = distance_m(a.home_m, b.home_m);
                if j > i && d < HOME_CLEARANCE_M {
                    problems.push(format!("{name} and {other} are {d:.3} m apart"));
                }
                if cam.may_see_sphere(b.home_m, BODY_RADIUS_M) {
                    problems.push(format!("{other} is in {name}'s field of view"));
                }
                let blocked =
                    segment_point_distance_m(cam.world_pos_m, PERFORMER_HOVER_M, b.home_m)
                        < BODY_RADIUS_M + GESTURE_RADIUS_M;
                if blocked {
                    problems.push(format!("{other} may hide the performer from {name}"));
                }
            }
        }
        problems
    }
}

/// Distance from `p` to the segment `a`–`b`, in space.
fn segment_point_distance_m(a: [f64; 3], b: [f64; 3], p: [f64; 3]) -> f64 {
    let ab = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let ap = [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
    let len2 = ab.iter().map(|v| v * v).sum::<f64>();
    let s = if len2 > 0.0 {
        (ab.iter().zip(ap).map(|(u, v)| u * v).sum::<f64>() / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    distance_m(p, [a[0] + s * ab[0], a[1] + s * ab[1], a[2] + s * ab[2]])
}

/// Focal length in pixels for the shared camera model.
pub fn focal_px() -> f64 {
    f64::from(IMAGE_HEIGHT_PX) / 2.0 / (CAMERA_FOVY_DEG.to_radians() / 2.0).tan()
}

/// A pinhole camera on a level airframe: position, yaw, and a fixed pitch below the horizon.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObserverCamera {
    pub world_pos_m: [f64; 3],
    pub yaw_rad: f64,
    pub pitch_rad: f64,
}

impl ObserverCamera {
    /// The camera of observer `i` of `n` of the built-in formation while it is at home.
    pub fn at_home(i: usize, n: usize) -> Self {
        Placement::aimed_from(observer_home_m(i, n)).camera()
    }

    /// A world point in camera coordinates: (forward, left, up), metres.
    pub fn camera_from_world(&self, world_m: [f64; 3]) -> [f64; 3] {
        self.camera_from_world_dir([
            world_m[0] - self.world_pos_m[0],
            world_m[1] - self.world_pos_m[1],
            world_m[2] - self.world_pos_m[2],
        ])
    }

    /// A camera-frame direction (forward, left, up) in world axes.
    pub fn world_from_camera_dir(&self, v: [f64; 3]) -> [f64; 3] {
        let [forward, left, up] = v;
        let (sp, cp) = self.pitch_rad.sin_cos();
        let level_forward = cp * forward + sp * up;
        let z = cp * up - sp * forward;
        let (s, c) = self.yaw_rad.sin_cos();
        [
            c * level_forward - s * left,
            s * level_forward + c * left,
            z,
        ]
    }

    /// A world direction in camera axes: (forward, left, up).
    pub fn camera_from_world_dir(&self, d: [f64; 3]) -> [f64; 3] {
        let (s, c) = self.yaw_rad.sin_cos();
        let level_forward = c * d[0] + s * d[1];
        let left = -s * d[0] + c * d[1];
        let (sp, cp) = self.pitch_rad.sin_cos();
        // With zero pitch these are exactly the level camera's forward and up.
        let forward = cp * level_forward - sp * d[2];
        let up = cp * d[2] + sp * level_forward;
        [forward, left, up]
    }

    /// Projects a world point into pixel coordinates (x right, y down, origin top-left corner
    /// of the top-left pixel). Returns `None` for points behind the camera.
    pub fn project_px(&self, world_m: [f64; 3]) -> Option<[f64; 2]> {
        Self::image_px(self.camera_from_world(world_m))
    }

    /// The camera-frame direction (forward, left, up) pixel `p` images, at unit forward
    /// distance ([`Self::image_px`] undone).
    pub fn ray_of_px(p: [f64; 2]) -> [f64; 3] {
        let f = focal_px();
        [
            1.0,
            (f64::from(IMAGE_WIDTH_PX) / 2.0 - p[0]) / f,
            (f64::from(IMAGE_HEIGHT_PX) / 2.0 - p[1]) / f,
        ]
    }

    /// The pixel a camera-frame direction (forward, left, up) images to; `None` behind the
    /// camera.
    pub fn image_px([forward, left, up]: [f64; 3]) -> Option<[f64; 2]> {
        if forward <= 1e-9 {
            return None;
        }
        let f = focal_px();
        Some([
            f64::from(IMAGE_WIDTH_PX) / 2.0 - f * left / forward,
            f64::from(IMAGE_HEIGHT_PX) / 2.0 - f * up / forward,
        ])
    }

    /// Half-extents of the image plane at unit depth: (horizontal, vertical).
    fn half_extents() -> (f64, f64) {
        let v = (CAMERA_FOVY_DEG.to_radians() / 2.0).tan();
        (
            v * f64::from(IMAGE_WIDTH_PX) / f64::from(IMAGE_HEIGHT_PX),
            v,
        )
    }

    /// Whether any part of the sphere may fall inside the image (conservative: true also for a
    /// sphere that merely touches the frustum's bounding planes).
    pub fn may_see_sphere(&self, center_m: [f64; 3], radius_m: f64) -> bool {
        let [x, y, z] = self.camera_from_world(center_m);
        let (hx, hy) = Self::half_extents();
        let outside = |a: f64, h: f64| (a - h * x) / h.hypot(1.0);
        // Signed distances outside the four side planes and behind the camera.
        x > -radius_m
            && outside(y, hx) < radius_m
            && outside(-y, hx) < radius_m
            && outside(z, hy) < radius_m
            && outside(-z, hy) < radius_m
    }

    /// Whether the whole sphere lies inside the image.
    pub fn sees_sphere(&self, center_m: [f64; 3], radius_m: f64) -> bool {
        let [x, y, z] = self.camera_from_world(center_m);
        let (hx, hy) = Self::half_extents();
        let inside = |a: f64, h: f64| (h * x - a) / h.hypot(1.0);
        x > radius_m
            && inside(y, hx) >= radius_m
            && inside(-y, hx) >= radius_m
            && inside(z, hy) >= radius_m
            && inside(-z, hy) >= radius_m
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
                let cam = ObserverCamera::at_home(i, n);
                let p = cam.project_px(PERFORMER_HOVER_M).expect("in front");
                assert!(
                    (p[0] - 320.0).abs() < 1e-9 && (p[1] - 240.0).abs() < 1e-9,
                    "{p:?}"
                );
                let up = [0.0, 0.0, 1.5];
                let q = cam.project_px(up).expect("in front");
                assert!(p[1] - q[1] >= 75.0, "0.2 m spans {} px", p[1] - q[1]);
            }
        }
    }

    #[test]
    fn world_x_moves_right_in_every_view() {
        for i in 0..3 {
            let cam = ObserverCamera::at_home(i, 3);
            let p = cam.project_px(PERFORMER_HOVER_M).unwrap();
            let q = cam.project_px([0.1, 0.0, 1.3]).unwrap();
            assert!(q[0] > p[0] + 20.0, "observer {i}: {p:?} -> {q:?}");
        }
    }

    #[test]
    fn the_paper_arc_is_unchanged_for_up_to_three_observers() {
        for n in 1..=3 {
            for i in 0..n {
                let home = observer_home_m(i, n);
                assert_eq!(home[2], PERFORMER_HOVER_M[2]);
                assert_eq!(observer_home_pitch_rad(home), 0.0);
                let a = (270.0 + (i as f64 - (n - 1) as f64 / 2.0) * 40.0).to_radians();
                assert_eq!(home[0], ARC_RADIUS_M * a.cos());
            }
        }
    }

    #[test]
    fn every_built_in_formation_keeps_clearance_cone_and_clear_views() {
        for n in 1..=MAX_OBSERVERS {
            let f = Formation::standard(n).unwrap();
            let problems = f.check(VIEWING_CONE_HALF_ANGLE_DEG);
            assert!(problems.is_empty(), "N = {n}: {problems:#?}");
        }
    }

    #[test]
    fn the_check_catches_crowding_a_wide_angle_and_an_observer_in_view() {
        // The old spread for N = 8 (160° of arc) views the plane at 80°.
        let wide = Formation::custom(vec![
            Placement::viewpoint(0.0, 0.0, 1.3),
            Placement::viewpoint(80.0, 0.0, 1.3),
        ])
        .unwrap();
        let p = wide.check(VIEWING_CONE_HALF_ANGLE_DEG);
        assert!(p.iter().any(|s| s.contains("O2 views")), "{p:?}");
        let crowded = Formation::custom(vec![
            Placement::viewpoint(0.0, 0.0, 1.3),
            Placement::viewpoint(5.0, 0.0, 1.3),
        ])
        .unwrap();
        let p = crowded.check(VIEWING_CONE_HALF_ANGLE_DEG);
        assert!(p.iter().any(|s| s.contains("apart")), "{p:?}");
        // A second row behind the first: the front observer is in view and in the way.
        let rows = Formation::custom(vec![
            Placement::viewpoint(0.0, 0.0, 1.3),
            Placement::viewpoint(0.0, 0.0, 2.6),
        ])
        .unwrap();
        let p = rows.check(VIEWING_CONE_HALF_ANGLE_DEG);
        assert!(p.iter().any(|s| s.contains("O1 is in O2's field")), "{p:?}");
        assert!(p.iter().any(|s| s.contains("O1 may hide")), "{p:?}");
    }

    #[test]
    fn pitch_zero_projects_exactly_like_a_level_camera() {
        let cam = ObserverCamera::at_home(0, 3);
        let p = [0.3, 0.1, 1.45];
        let d = [
            p[0] - cam.world_pos_m[0],
            p[1] - cam.world_pos_m[1],
            p[2] - cam.world_pos_m[2],
        ];
        let (s, c) = cam.yaw_rad.sin_cos();
        let forward = c * d[0] + s * d[1];
        let left = -s * d[0] + c * d[1];
        assert_eq!(cam.camera_from_world(p), [forward, left, d[2]]);
    }

    #[test]
    fn viewing_angles_of_the_groups() {
        let angles = |n: usize| -> Vec<f64> {
            Formation::standard(n)
                .unwrap()
                .placements()
                .iter()
                .map(|p| p.viewing_angle_rad().to_degrees())
                .collect()
        };
        let three = angles(3);
        assert!(
            (three[0] - 40.0).abs() < 1e-9 && three[1].abs() < 1e-6,
            "{three:?}"
        );
        for n in 4..=MAX_OBSERVERS {
            let worst = angles(n).into_iter().fold(0.0, f64::max);
            assert!(worst > 35.0 && worst < 40.0, "N = {n}: {worst}");
        }
        let v = Placement::viewpoint(60.0, 0.0, 2.0);
        assert!((v.viewing_angle_rad().to_degrees() - 60.0).abs() < 1e-9);
        assert!((v.distance_m() - 2.0).abs() < 1e-12);
    }
}
