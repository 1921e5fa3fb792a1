//! A real camera's geometry, and the remap of its pixels into the receivers' reference camera.
//!
//! The receivers are built for one camera: a 640×480 pinhole with a 45° vertical field of view
//! and its principal point at the image centre (`proto::scene`). A recording from any other
//! camera (another resolution, another lens, lens distortion) is remapped into that reference
//! before it reaches a receiver: each source pixel is undistorted to a ray, and the ray is
//! projected with the reference camera's intrinsics, to the nearest reference pixel. Rays that
//! fall outside the reference image are dropped, so a wider lens is cropped to 45° and a
//! narrower one fills only the middle of the reference image.
//!
//! Geometry comes from a calibration file in ROS `camera_info` YAML
//! (`camera_calibration_parsers`' format) or OpenCV's `FileStorage` YAML (as OpenCV's
//! calibration sample writes it: `%YAML:1.0`, `!!opencv-matrix` tags), with the `plumb_bob` /
//! `rational_polynomial` distortion models (OpenCV's radial-tangential model with up to eight
//! coefficients). Pixel coordinates follow their convention: pixel `(u, v)` has its centre at
//! `(u, v)`. Without a file, a camera of another resolution is taken to have the reference's
//! 45° vertical field of view, square pixels, its principal point at the centre and no
//! distortion.

use std::path::Path;

use thiserror::Error;

/// Why a calibration could not be read or applied.
#[derive(Debug, Error)]
pub enum CalibrationError {
    #[error("reading camera calibration {path}")]
    Read {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("camera calibration {path}")]
    File {
        path: String,
        #[source]
        source: Box<CalibrationError>,
    },
    #[error("not a camera_info / OpenCV YAML document")]
    Yaml {
        #[source]
        source: serde_yaml::Error,
    },
    #[error("{0}")]
    Invalid(String),
}

type Result<T, E = CalibrationError> = std::result::Result<T, E>;

/// Refuses with [`CalibrationError::Invalid`] and a formatted reason.
macro_rules! bail {
    ($($arg:tt)*) => {
        return Err(CalibrationError::Invalid(format!($($arg)*)))
    };
}
use proto::scene::{IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX, focal_px};
use serde::Deserialize;

/// Largest image side, px, that a calibration or a remapped stream may have. A remap holds one
/// entry per source pixel and computes each once, so the size a file or a message states bounds
/// the memory (4096² pixels: 64 MiB) and the time it costs; 4096 holds a 4K camera and twice the
/// largest sensor EVT 3.0 can carry.
pub const MAX_SIDE_PX: u16 = 4096;

/// Radial-tangential distortion coefficients `k1 k2 p1 p2 k3 k4 k5 k6` (OpenCV's order; missing
/// ones are zero).
pub type Distortion = [f64; 8];

/// One camera's intrinsics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intrinsics {
    pub width_px: u16,
    pub height_px: u16,
    pub fx_px: f64,
    pub fy_px: f64,
    /// Principal point, pixel-centre convention (the centre of pixel 0 is 0).
    pub cx_px: f64,
    pub cy_px: f64,
    pub distortion: Distortion,
}

impl Intrinsics {
    /// The receivers' reference camera.
    pub fn reference() -> Self {
        Self::pinhole_like_reference(IMAGE_WIDTH_PX, IMAGE_HEIGHT_PX)
    }

    /// A `width`×`height` camera with the reference's vertical field of view, square pixels, a
    /// centred principal point and no distortion.
    pub fn pinhole_like_reference(width_px: u16, height_px: u16) -> Self {
        let f = focal_px() * f64::from(height_px) / f64::from(IMAGE_HEIGHT_PX);
        Self {
            width_px,
            height_px,
            fx_px: f,
            fy_px: f,
            cx_px: (f64::from(width_px) - 1.0) / 2.0,
            cy_px: (f64::from(height_px) - 1.0) / 2.0,
            distortion: [0.0; 8],
        }
    }

    /// The camera of a `width`×`height` recording or stream (`size`, when known): the
    /// calibration file's, or one like the reference; `None` when nothing needs remapping.
    ///
    /// # Errors
    ///
    /// A calibration file that cannot be read, or whose size is not the recording's.
    pub fn of_recording(
        calibration: Option<&Path>,
        size: Option<(u16, u16)>,
    ) -> Result<Option<Self>> {
        let reference = (IMAGE_WIDTH_PX, IMAGE_HEIGHT_PX);
        match calibration {
            Some(path) => {
                let cam = Intrinsics::from_file(path)?;
                if let Some((w, h)) = size.filter(|&s| s != (cam.width_px, cam.height_px)) {
                    bail!(
                        "the recording is {w}×{h} but the calibration {} is for {}×{}",
                        path.display(),
                        cam.width_px,
                        cam.height_px
                    );
                }
                Ok(Some(cam))
            }
            None => {
                if let Some((w, h)) = size.filter(|&(w, h)| w > MAX_SIDE_PX || h > MAX_SIDE_PX) {
                    bail!(
                        "a {w}×{h} stream is larger than the {MAX_SIDE_PX}×{MAX_SIDE_PX} pixels \
                         a remap into the reference camera is built for"
                    );
                }
                Ok(size
                    .filter(|&s| s != reference)
                    .map(|(w, h)| Intrinsics::pinhole_like_reference(w, h)))
            }
        }
    }

    /// Reads a ROS `camera_info` or OpenCV calibration YAML file.
    pub fn from_file(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|source| CalibrationError::Read {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_yaml(&text).map_err(|e| CalibrationError::File {
            path: path.display().to_string(),
            source: Box::new(e),
        })
    }

    /// Parses a ROS `camera_info` or OpenCV calibration YAML document.
    pub fn from_yaml(text: &str) -> Result<Self> {
        // OpenCV's FileStorage writes a `%YAML:1.0` directive and `!!opencv-matrix` tags, which
        // a YAML 1.2 parser refuses; the rest is plain YAML.
        let cleaned: String = text
            .lines()
            .filter(|l| !l.trim_start().starts_with("%YAML"))
            .map(|l| l.replace("!!opencv-matrix", "") + "\n")
            .collect();
        let file: CalibrationFile =
            serde_yaml::from_str(&cleaned).map_err(|source| CalibrationError::Yaml { source })?;
        file.intrinsics()
    }

    fn check(&self) -> Result<()> {
        if self.width_px == 0 || self.height_px == 0 {
            bail!("image size {}×{} is empty", self.width_px, self.height_px);
        }
        let finite = [self.fx_px, self.fy_px, self.cx_px, self.cy_px]
            .iter()
            .chain(&self.distortion)
            .all(|v| v.is_finite());
        if !finite || self.fx_px <= 0.0 || self.fy_px <= 0.0 {
            bail!(
                "camera matrix fx {} fy {} cx {} cy {}: focal lengths must be positive and \
                 every value finite",
                self.fx_px,
                self.fy_px,
                self.cx_px,
                self.cy_px
            );
        }
        Ok(())
    }

    /// Distorts normalised image coordinates (OpenCV's radial-tangential model).
    fn distort(&self, x: f64, y: f64) -> (f64, f64) {
        let [k1, k2, p1, p2, k3, k4, k5, k6] = self.distortion;
        let r2 = x * x + y * y;
        let radial =
            (1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))) / (1.0 + r2 * (k4 + r2 * (k5 + r2 * k6)));
        (
            x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
            y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y,
        )
    }

    /// The normalised coordinates whose distortion is `(xd, yd)`: fixed-point iteration, as
    /// OpenCV's `undistortPoints`, with a fixed count so the result is deterministic.
    fn undistort(&self, xd: f64, yd: f64) -> (f64, f64) {
        if self.distortion == [0.0; 8] {
            return (xd, yd);
        }
        let (mut x, mut y) = (xd, yd);
        for _ in 0..30 {
            let (dx, dy) = self.distort(x, y);
            x += xd - dx;
            y += yd - dy;
        }
        (x, y)
    }

    /// Where the centre of pixel `(u, v)` of this camera lands in the reference camera
    /// (pixel-centre convention), or `None` behind a distortion that does not converge.
    fn reference_pixel_of(&self, reference: &Intrinsics, u: f64, v: f64) -> Option<(f64, f64)> {
        let (xd, yd) = ((u - self.cx_px) / self.fx_px, (v - self.cy_px) / self.fy_px);
        let (x, y) = self.undistort(xd, yd);
        let (rx, ry) = self.distort(x, y);
        // A lens model evaluated far outside its calibrated field may have no inverse there.
        if !((rx - xd).abs() < 1e-6 && (ry - yd).abs() < 1e-6) {
            return None;
        }
        Some((
            reference.fx_px * x + reference.cx_px,
            reference.fy_px * y + reference.cy_px,
        ))
    }

    /// Where the reference camera's pixel `(u, v)` lies in this camera's image.
    fn own_pixel_of(&self, reference: &Intrinsics, u: f64, v: f64) -> (f64, f64) {
        let (x, y) = (
            (u - reference.cx_px) / reference.fx_px,
            (v - reference.cy_px) / reference.fy_px,
        );
        let (xd, yd) = self.distort(x, y);
        (self.fx_px * xd + self.cx_px, self.fy_px * yd + self.cy_px)
    }
}

/// The fields both YAML dialects share.
#[derive(Debug, Deserialize)]
struct CalibrationFile {
    image_width: u32,
    image_height: u32,
    camera_matrix: Matrix,
    #[serde(default)]
    distortion_model: Option<String>,
    #[serde(default, alias = "distortion_coefficients")]
    distortion_coefficients: Option<Matrix>,
}

#[derive(Debug, Deserialize)]
struct Matrix {
    #[serde(default)]
    rows: Option<u32>,
    #[serde(default)]
    cols: Option<u32>,
    data: Vec<f64>,
}

impl CalibrationFile {
    fn intrinsics(&self) -> Result<Intrinsics> {
        let size = |v: u32, what: &str| {
            u16::try_from(v)
                .ok()
                .filter(|&v| (1..=MAX_SIDE_PX).contains(&v))
                .ok_or_else(|| {
                    CalibrationError::Invalid(format!(
                        "{what} {v} is outside 1..={MAX_SIDE_PX} pixels"
                    ))
                })
        };
        let k = &self.camera_matrix;
        if k.data.len() != 9 || k.rows.is_some_and(|r| r != 3) || k.cols.is_some_and(|c| c != 3) {
            bail!(
                "camera_matrix must be 3×3 (9 values); it has {} values",
                k.data.len()
            );
        }
        let model = self.distortion_model.as_deref().unwrap_or("plumb_bob");
        if !matches!(model, "plumb_bob" | "rational_polynomial") {
            bail!(
                "distortion_model {model:?} is not supported (plumb_bob and rational_polynomial \
                 are)"
            );
        }
        let coefficients = self
            .distortion_coefficients
            .as_ref()
            .map_or(&[][..], |d| &d.data);
        if coefficients.len() > 8 {
            bail!(
                "{} distortion coefficients; the {model} model has at most 8 (k1 k2 p1 p2 k3 k4 \
                 k5 k6)",
                coefficients.len()
            );
        }
        let mut distortion = [0.0; 8];
        distortion[..coefficients.len()].copy_from_slice(coefficients);
        let intrinsics = Intrinsics {
            width_px: size(self.image_width, "image_width")?,
            height_px: size(self.image_height, "image_height")?,
            fx_px: k.data[0],
            fy_px: k.data[4],
            cx_px: k.data[2],
            cy_px: k.data[5],
            distortion,
        };
        intrinsics.check()?;
        Ok(intrinsics)
    }
}

/// Source pixels → reference pixels, computed once per camera.
#[derive(Debug, Clone)]
pub struct EventRemap {
    width_px: u16,
    height_px: u16,
    /// Per source pixel (row-major): the reference pixel index, or `u32::MAX` outside it.
    to_reference: Vec<u32>,
}

/// A pixel with no reference pixel.
const OUTSIDE: u32 = u32::MAX;

impl EventRemap {
    /// The remap of `source`'s pixels into the reference camera.
    pub fn new(source: &Intrinsics) -> Self {
        let reference = Intrinsics::reference();
        let (w, h) = (
            usize::from(reference.width_px),
            usize::from(reference.height_px),
        );
        let mut to_reference =
            Vec::with_capacity(usize::from(source.width_px) * usize::from(source.height_px));
        for v in 0..source.height_px {
            for u in 0..source.width_px {
                let index = source
                    .reference_pixel_of(&reference, f64::from(u), f64::from(v))
                    .map(|(x, y)| (x.round(), y.round()))
                    .filter(|&(x, y)| x >= 0.0 && y >= 0.0 && x < w as f64 && y < h as f64)
                    .map_or(OUTSIDE, |(x, y)| (y as usize * w + x as usize) as u32);
                to_reference.push(index);
            }
        }
        Self {
            width_px: source.width_px,
            height_px: source.height_px,
            to_reference,
        }
    }

    /// The reference pixel of source pixel `(x, y)`, if it has one.
    pub fn map(&self, x: u16, y: u16) -> Option<(u16, u16)> {
        if x >= self.width_px || y >= self.height_px {
            return None;
        }
        let i = self.to_reference[usize::from(y) * usize::from(self.width_px) + usize::from(x)];
        (i != OUTSIDE).then(|| {
            let w = u32::from(IMAGE_WIDTH_PX);
            ((i % w) as u16, (i / w) as u16)
        })
    }
}

/// Reference pixels → source pixels (nearest), for images.
#[derive(Debug, Clone)]
pub struct ImageRemap {
    width_px: u16,
    height_px: u16,
    /// Per reference pixel (row-major): the source pixel index, or `u32::MAX` outside it.
    from_source: Vec<u32>,
}

impl ImageRemap {
    /// The remap of `source`'s images into the reference camera.
    pub fn new(source: &Intrinsics) -> Self {
        let reference = Intrinsics::reference();
        let (w, h) = (f64::from(source.width_px), f64::from(source.height_px));
        let mut from_source =
            Vec::with_capacity(usize::from(reference.width_px) * usize::from(reference.height_px));
        for v in 0..reference.height_px {
            for u in 0..reference.width_px {
                let (x, y) = source.own_pixel_of(&reference, f64::from(u), f64::from(v));
                let (x, y) = (x.round(), y.round());
                let inside = x >= 0.0 && y >= 0.0 && x < w && y < h;
                from_source.push(if inside { (y * w + x) as u32 } else { OUTSIDE });
            }
        }
        Self {
            width_px: source.width_px,
            height_px: source.height_px,
            from_source,
        }
    }

    /// `rgb` (this camera's image, 3 bytes a pixel) as the reference camera would see it; what
    /// lies outside the source image is black.
    pub fn apply(&self, rgb: &[u8]) -> Result<Vec<u8>> {
        let want = usize::from(self.width_px) * usize::from(self.height_px) * 3;
        if rgb.len() != want {
            bail!(
                "an image of {} bytes; a {}×{} RGB image has {want}",
                rgb.len(),
                self.width_px,
                self.height_px
            );
        }
        let mut out = Vec::with_capacity(self.from_source.len() * 3);
        for &i in &self.from_source {
            if i == OUTSIDE {
                out.extend_from_slice(&[0, 0, 0]);
            } else {
                let i = i as usize * 3;
                out.extend_from_slice(&rgb[i..i + 3]);
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ROS: &str = r#"image_width: 1280
image_height: 960
camera_name: dvxplorer
camera_matrix:
  rows: 3
  cols: 3
  data: [1100.0, 0, 640.5, 0, 1100.0, 470.0, 0, 0, 1]
distortion_model: plumb_bob
distortion_coefficients:
  rows: 1
  cols: 5
  data: [-0.21, 0.04, 0.001, -0.002, 0.0]
rectification_matrix:
  rows: 3
  cols: 3
  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]
"#;

    const OPENCV: &str = r#"%YAML:1.0
---
image_width: 346
image_height: 260
camera_matrix: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ 2.5e+02, 0., 1.73e+02, 0., 2.5e+02, 1.3e+02, 0., 0., 1. ]
distortion_coefficients: !!opencv-matrix
   rows: 5
   cols: 1
   dt: d
   data: [ -0.3, 0.1, 0., 0., 0. ]
"#;

    #[test]
    fn both_yaml_dialects_parse() {
        let ros = Intrinsics::from_yaml(ROS).unwrap();
        assert_eq!((ros.width_px, ros.height_px), (1280, 960));
        assert_eq!((ros.fx_px, ros.cx_px, ros.cy_px), (1100.0, 640.5, 470.0));
        assert_eq!(ros.distortion[..4], [-0.21, 0.04, 0.001, -0.002]);
        let cv = Intrinsics::from_yaml(OPENCV).unwrap();
        assert_eq!((cv.width_px, cv.height_px, cv.fy_px), (346, 260, 250.0));
        assert_eq!(cv.distortion[..2], [-0.3, 0.1]);
    }

    #[test]
    fn bad_files_are_refused_naming_the_field() {
        let err = |t: &str| format!("{:#}", Intrinsics::from_yaml(t).unwrap_err());
        assert!(err(&ROS.replace("plumb_bob", "equidistant")).contains("equidistant"));
        assert!(err(&ROS.replace("1100.0, 0, 640.5", "1100.0, 640.5")).contains("3×3"));
        assert!(err(&ROS.replace("1100.0, 0, 640.5", "-1.0, 0, 640.5")).contains("positive"));
        assert!(err(&ROS.replace("image_width: 1280", "image_width: 0")).contains("image_width"));
        assert!(err("image_width: [").contains("YAML"));
    }

    #[test]
    fn the_reference_camera_maps_onto_itself() {
        let remap = EventRemap::new(&Intrinsics::reference());
        for (x, y) in [(0, 0), (639, 479), (320, 240), (17, 401)] {
            assert_eq!(remap.map(x, y), Some((x, y)));
        }
        assert_eq!(remap.map(640, 0), None);
        let image = ImageRemap::new(&Intrinsics::reference());
        let rgb: Vec<u8> = (0..640 * 480 * 3).map(|i| (i % 251) as u8).collect();
        assert_eq!(image.apply(&rgb).unwrap(), rgb);
    }

    #[test]
    fn a_distorted_camera_undoes_its_distortion() {
        let cam = Intrinsics::from_yaml(ROS).unwrap();
        let reference = Intrinsics::reference();
        // A reference pixel seen through the lens and back lands where it started.
        for (u, v) in [(320.0, 240.0), (10.0, 20.0), (600.0, 450.0)] {
            let (x, y) = cam.own_pixel_of(&reference, u, v);
            let (u2, v2) = cam.reference_pixel_of(&reference, x, y).unwrap();
            assert!((u2 - u).abs() < 1e-6 && (v2 - v).abs() < 1e-6, "{u},{v}");
        }
        // Twice the reference's resolution and focal length: pixel 2x maps to x.
        let double = Intrinsics {
            width_px: 1280,
            height_px: 960,
            fx_px: 2.0 * reference.fx_px,
            fy_px: 2.0 * reference.fy_px,
            cx_px: 639.5,
            cy_px: 479.5,
            distortion: [0.0; 8],
        };
        let remap = EventRemap::new(&double);
        assert_eq!(remap.map(2 * 100, 2 * 50), Some((100, 50)));
        assert_eq!(remap.map(1279, 959), Some((639, 479)));
    }

    #[test]
    fn a_wider_lens_is_cropped_to_the_reference_field() {
        // A 90° vertical field at 640×480: the outer quarter of each side lies outside.
        let wide = Intrinsics {
            fx_px: 239.5,
            fy_px: 239.5,
            ..Intrinsics::reference()
        };
        let remap = EventRemap::new(&wide);
        assert_eq!(remap.map(0, 240), None);
        // Half the focal length: a pixel half a pixel right of the centre lands 1.2 px right.
        assert_eq!(remap.map(320, 240), Some((321, 241)));
    }

    #[test]
    fn sizes_beyond_a_remap_are_refused_before_allocating() {
        let huge = OPENCV.replace("image_width: 346", "image_width: 65535");
        let e = Intrinsics::from_yaml(&huge).unwrap_err();
        assert!(
            e.to_string()
                .contains("image_width 65535 is outside 1..=4096"),
            "{e}"
        );
        let e = Intrinsics::of_recording(None, Some((65535, 480))).unwrap_err();
        assert!(e.to_string().contains("65535×480"), "{e}");
        assert!(Intrinsics::of_recording(None, Some((4096, 4096))).is_ok());
    }
}
