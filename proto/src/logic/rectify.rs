//! Viewpoint rectification: maps the receiver's image-plane trajectory to what a camera at the
//! same place but aimed differently would have seen, before the segmenter matches templates.
//!
//! Each observer knows the map (its home and the performer's hover point, as the paper
//! assumes), hence its camera's pose. A pure rotation of a pinhole camera about its centre is a
//! homography of the image, independent of the scene, so the rectified trajectory is exact:
//! - [`Rectification::Frontal`] turns the virtual camera to face the gesture plane along its
//!   normal: the image plane becomes parallel to the gesture plane and the trajectory is the
//!   flown one up to scale and offset, whatever the azimuth (until the symbols' image is too
//!   small or foreshortened for the tracker itself).
//! - [`Rectification::Pitched`] (default) does that only for cameras that are not level (the
//!   group formation's upper row). Undoing the pitch alone is not enough: from above and to the
//!   side, the plane's horizontal strokes below the camera tilt by ≈ 15° in a level view. Level
//!   cameras keep the raw trajectory, which the paper's arc (±40°) decodes, so its runs stay
//!   bit for bit as they were.
//!
//! The rectified trajectory is re-centred so the hover point lands where the real camera sees it.

use crate::scene::{IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX};
use crate::scene::{ObserverCamera, PERFORMER_HOVER_M, focal_px};
use crate::segmenter::Sample;

/// Which virtual camera the segmenter sees through.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Rectification {
    /// No rectification: the raw image trajectory.
    Off,
    /// [`Self::Frontal`] for pitched cameras, none for level ones.
    #[default]
    Pitched,
    /// Face the gesture plane head-on (plane normal, +y), every camera.
    Frontal,
}

impl Rectification {
    pub const ALL: [Self; 3] = [Self::Off, Self::Pitched, Self::Frontal];

    pub fn as_str(self) -> &'static str {
        match self {
            Self::Off => "off",
            Self::Pitched => "pitched",
            Self::Frontal => "frontal",
        }
    }
}

impl std::fmt::Display for Rectification {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl std::str::FromStr for Rectification {
    type Err = crate::UnknownName;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        crate::modality::parse_name(
            &Self::ALL,
            |r| r.as_str(),
            s,
            "rectification",
            "off, level, frontal",
        )
    }
}

/// The image-to-image map of one camera (a rotation homography plus a re-centring shift).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rectifier {
    real: ObserverCamera,
    virtual_camera: ObserverCamera,
    shift_px: [f64; 2],
}

impl Rectifier {
    /// The map for `camera` under `mode`; `None` when none applies (mode off, or a level
    /// camera under [`Rectification::Pitched`]).
    pub fn new(camera: ObserverCamera, mode: Rectification) -> Option<Self> {
        match mode {
            Rectification::Off => return None,
            Rectification::Pitched if camera.pitch_rad == 0.0 => return None,
            Rectification::Pitched | Rectification::Frontal => {}
        }
        let virtual_camera = ObserverCamera {
            yaw_rad: std::f64::consts::FRAC_PI_2,
            pitch_rad: 0.0,
            ..camera
        };
        let mut r = Self {
            real: camera,
            virtual_camera,
            shift_px: [0.0, 0.0],
        };
        let seen = camera.project_px(PERFORMER_HOVER_M)?;
        let mapped = r.map_px(seen)?;
        r.shift_px = [seen[0] - mapped[0], seen[1] - mapped[1]];
        Some(r)
    }

    /// Where pixel `p` of the real camera lands in the virtual one; `None` for a ray behind the
    /// virtual camera.
    pub fn map_px(&self, p: [f64; 2]) -> Option<[f64; 2]> {
        let f = focal_px();
        let (cx, cy) = (
            f64::from(IMAGE_WIDTH_PX) / 2.0,
            f64::from(IMAGE_HEIGHT_PX) / 2.0,
        );
        let ray_camera = [1.0, (cx - p[0]) / f, (cy - p[1]) / f];
        let ray_world = self.real.world_from_camera_dir(ray_camera);
        let [forward, left, up] = self.virtual_camera.camera_from_world_dir(ray_world);
        if forward <= 1e-9 {
            return None;
        }
        Some([
            cx - f * left / forward + self.shift_px[0],
            cy - f * up / forward + self.shift_px[1],
        ])
    }

    /// The sample as the virtual camera would have given it (a point that cannot be mapped is
    /// an unreliable sample without a point).
    pub fn sample(&self, sample: Sample) -> Sample {
        sample.mapped(|p| self.map_px(p))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Placement, observer_home_m};

    /// Image of a point of the gesture plane (x, z offsets from the hover point).
    fn seen(camera: &ObserverCamera, dx: f64, dz: f64) -> [f64; 2] {
        let h = PERFORMER_HOVER_M;
        camera.project_px([h[0] + dx, h[1], h[2] + dz]).unwrap()
    }

    #[test]
    fn pitched_leaves_level_cameras_alone_and_off_applies_to_none() {
        let level = Placement::aimed_from(observer_home_m(0, 3)).camera();
        assert_eq!(Rectifier::new(level, Rectification::Pitched), None);
        assert!(Rectifier::new(level, Rectification::Frontal).is_some());
        let pitched = Placement::aimed_from(observer_home_m(1, 8)).camera();
        assert!(pitched.pitch_rad > 0.3);
        assert_eq!(Rectifier::new(pitched, Rectification::Off), None);
        assert_eq!(
            Rectifier::new(pitched, Rectification::Pitched),
            Rectifier::new(pitched, Rectification::Frontal)
        );
    }

    #[test]
    fn frontal_recovers_the_flown_shape_at_steep_azimuths() {
        for az in [0.0, 40.0, 60.0, 75.0] {
            let cam = Placement::viewpoint(az, 20.0, 1.6).camera();
            let r = Rectifier::new(cam, Rectification::Frontal).unwrap();
            let o = r.map_px(seen(&cam, 0.0, 0.0)).unwrap();
            let x = r.map_px(seen(&cam, 0.1, 0.0)).unwrap();
            let z = r.map_px(seen(&cam, 0.0, 0.1)).unwrap();
            let d = r.map_px(seen(&cam, 0.1, 0.1)).unwrap();
            // +x right, +z up, equal scale, and a parallelogram (no keystone).
            let (ux, uz) = ([x[0] - o[0], x[1] - o[1]], [z[0] - o[0], z[1] - o[1]]);
            assert!(ux[0] > 10.0 && ux[1].abs() < 1e-6, "az {az}: {ux:?}");
            assert!(uz[1] < -10.0 && uz[0].abs() < 1e-6, "az {az}: {uz:?}");
            assert!((ux[0] + uz[1]).abs() < 1e-6, "az {az}: {ux:?} {uz:?}");
            assert!((d[0] - (o[0] + ux[0] + uz[0])).abs() < 1e-6, "az {az}");
            assert!((d[1] - (o[1] + ux[1] + uz[1])).abs() < 1e-6, "az {az}");
            // The hover point stays where the real camera sees it.
            let c = seen(&cam, 0.0, 0.0);
            assert!((o[0] - c[0]).abs() < 1e-6 && (o[1] - c[1]).abs() < 1e-6);
        }
    }

    #[test]
    fn a_sample_without_a_point_passes_and_names_parse() {
        let cam = Placement::viewpoint(50.0, 10.0, 1.3).camera();
        let r = Rectifier::new(cam, Rectification::Frontal).unwrap();
        let s = Sample::lost(7);
        assert_eq!(r.sample(s), s);
        for m in Rectification::ALL {
            assert_eq!(m.as_str().parse::<Rectification>(), Ok(m));
        }
        assert!("sideways".parse::<Rectification>().is_err());
    }
}
