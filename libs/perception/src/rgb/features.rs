//! Shi–Tomasi good features to track, inside a rectangular region of the frame.

use image::GrayImage;
use optical_flow_lk::DetectorContext;

use crate::rgb::error::RgbReceiverError;

/// Detection settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeatureConfig {
    /// Keep corners scoring at least this fraction of the strongest one in the region.
    pub quality_level: f32,
    /// Absolute score floor ((grey level / px)², minimum eigenvalue of the mean 3×3 Scharr
    /// structure tensor): a region without real texture — a blank, black or uniform frame —
    /// yields nothing instead of its strongest noise.
    pub min_score: f32,
    /// Minimum spacing between features, pixels.
    pub min_distance_px: u32,
}

impl FeatureConfig {
    pub fn paper() -> Self {
        Self {
            quality_level: 0.05,
            min_score: 20.0,
            min_distance_px: 3,
        }
    }

    pub fn validate(&self) -> Result<(), RgbReceiverError> {
        if !(self.quality_level.is_finite() && (0.0..1.0).contains(&self.quality_level)) {
            return Err(RgbReceiverError::BadConfig(
                "features: quality_level must be in [0, 1)".into(),
            ));
        }
        if !(self.min_score.is_finite() && self.min_score > 0.0) {
            return Err(RgbReceiverError::BadConfig(
                "features: min_score must be positive".into(),
            ));
        }
        Ok(())
    }
}

impl Default for FeatureConfig {
    fn default() -> Self {
        Self::paper()
    }
}

/// A half-open pixel rectangle `[x0, x1) × [y0, y1)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Region {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

impl Region {
    /// The rectangle of half-size `half_px` around `centre_px`, clipped to a `width × height`
    /// image; `None` when nothing of it (or fewer than 3 × 3 pixels) is inside.
    pub fn around(centre_px: [f64; 2], half_px: [f64; 2], width: u32, height: u32) -> Option<Self> {
        if !(centre_px.iter().chain(&half_px).all(|v| v.is_finite())) {
            return None;
        }
        let clip = |v: f64, hi: u32| v.round().clamp(0.0, f64::from(hi)) as u32;
        let r = Self {
            x0: clip(centre_px[0] - half_px[0], width),
            y0: clip(centre_px[1] - half_px[1], height),
            x1: clip(centre_px[0] + half_px[0] + 1.0, width),
            y1: clip(centre_px[1] + half_px[1] + 1.0, height),
        };
        (r.x1 >= r.x0 + 3 && r.y1 >= r.y0 + 3).then_some(r)
    }

    pub fn width(&self) -> u32 {
        self.x1 - self.x0
    }

    pub fn height(&self) -> u32 {
        self.y1 - self.y0
    }

    pub fn contains(&self, p: [f64; 2]) -> bool {
        p[0] >= f64::from(self.x0)
            && p[0] < f64::from(self.x1)
            && p[1] >= f64::from(self.y0)
            && p[1] < f64::from(self.y1)
    }
}

/// A detected feature: image position (pixels) and Shi–Tomasi score.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Feature {
    pub point_px: [f32; 2],
    pub score: f32,
}

/// Shi–Tomasi detector with reusable buffers.
#[derive(Default)]
pub struct FeatureDetector {
    ctx: DetectorContext,
    crop: GrayImage,
}

impl std::fmt::Debug for FeatureDetector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FeatureDetector").finish_non_exhaustive()
    }
}

impl Clone for FeatureDetector {
    /// Buffers are scratch state; the clone starts empty.
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl FeatureDetector {
    pub fn new() -> Self {
        Self::default()
    }

    /// Up to `max` features inside `region` of `image`, strongest first, at least
    /// `min_distance_px` from each other and from every point of `existing`.
    pub fn detect(
        &mut self,
        image: &GrayImage,
        region: Region,
        existing: &[[f32; 2]],
        max: usize,
        config: &FeatureConfig,
    ) -> Vec<Feature> {
        let (w, h) = image.dimensions();
        let region = Region {
            x0: region.x0.min(w),
            y0: region.y0.min(h),
            x1: region.x1.min(w),
            y1: region.y1.min(h),
        };
        if max == 0 || region.width() < 3 || region.height() < 3 {
            return Vec::new();
        }
        if self.crop.dimensions() != (region.width(), region.height()) {
            self.crop = GrayImage::new(region.width(), region.height());
        }
        let src: &[u8] = image;
        let dst: &mut [u8] = &mut self.crop;
        let (cw, stride) = (region.width() as usize, w as usize);
        for (row, out) in dst.chunks_exact_mut(cw).enumerate() {
            let start = (region.y0 as usize + row) * stride + region.x0 as usize;
            out.copy_from_slice(&src[start..start + cw]);
        }
        let corners = self
            .ctx
            .detect(&self.crop, config.quality_level, config.min_distance_px);
        let min_d2 = f64::from(config.min_distance_px).powi(2);
        let clear = |p: [f32; 2]| {
            existing.iter().all(|q| {
                let (dx, dy) = (f64::from(p[0] - q[0]), f64::from(p[1] - q[1]));
                dx * dx + dy * dy >= min_d2
            })
        };
        corners
            .iter()
            .take_while(|c| c.score >= config.min_score)
            .map(|c| Feature {
                point_px: [(c.x + region.x0) as f32, (c.y + region.y0) as f32],
                score: c.score,
            })
            .filter(|f| clear(f.point_px))
            .take(max)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image_with_square(w: u32, h: u32, x0: u32, y0: u32, side: u32) -> GrayImage {
        GrayImage::from_fn(w, h, |x, y| {
            let inside = (x0..x0 + side).contains(&x) && (y0..y0 + side).contains(&y);
            image::Luma([if inside { 220 } else { 60 }])
        })
    }

    #[test]
    fn finds_the_corners_of_a_square_only_inside_the_region() {
        let img = image_with_square(120, 80, 30, 20, 20);
        let mut d = FeatureDetector::new();
        let cfg = FeatureConfig::paper();
        let all = d.detect(
            &img,
            Region {
                x0: 0,
                y0: 0,
                x1: 120,
                y1: 80,
            },
            &[],
            50,
            &cfg,
        );
        assert!(all.len() >= 4, "{all:?}");
        for f in &all {
            let near_corner = [[30.0, 20.0], [49.0, 20.0], [30.0, 39.0], [49.0, 39.0]]
                .iter()
                .any(|c: &[f32; 2]| {
                    (f.point_px[0] - c[0]).abs() <= 2.0 && (f.point_px[1] - c[1]).abs() <= 2.0
                });
            assert!(near_corner, "{f:?} is not at a corner of the square");
        }
        // A region holding only the left half of the square sees only its left corners.
        let left = d.detect(
            &img,
            Region {
                x0: 20,
                y0: 10,
                x1: 40,
                y1: 50,
            },
            &[],
            50,
            &cfg,
        );
        assert!(!left.is_empty());
        assert!(left.iter().all(|f| f.point_px[0] < 35.0), "{left:?}");
        // Existing points keep new ones away.
        let existing: Vec<[f32; 2]> = all.iter().map(|f| f.point_px).collect();
        let again = d.detect(
            &img,
            Region {
                x0: 0,
                y0: 0,
                x1: 120,
                y1: 80,
            },
            &existing,
            50,
            &cfg,
        );
        assert!(again.is_empty(), "{again:?}");
    }

    #[test]
    fn blank_and_faint_images_yield_no_features() {
        let mut d = FeatureDetector::new();
        let cfg = FeatureConfig::paper();
        let full = Region {
            x0: 0,
            y0: 0,
            x1: 64,
            y1: 48,
        };
        assert!(
            d.detect(&GrayImage::new(64, 48), full, &[], 50, &cfg)
                .is_empty()
        );
        // A one-level step pattern: real corners, but far below the absolute floor.
        let faint = GrayImage::from_fn(64, 48, |x, y| {
            image::Luma([100 + u8::from(x > 30 && y > 20)])
        });
        assert!(d.detect(&faint, full, &[], 50, &cfg).is_empty());
    }

    #[test]
    fn region_around_clips_to_the_image() {
        let r = Region::around([5.0, 5.0], [10.0, 4.0], 100, 50).unwrap();
        assert_eq!(
            r,
            Region {
                x0: 0,
                y0: 1,
                x1: 16,
                y1: 10
            }
        );
        assert!(Region::around([500.0, 5.0], [10.0, 4.0], 100, 50).is_none());
        assert!(Region::around([f64::NAN, 5.0], [10.0, 4.0], 100, 50).is_none());
    }
}
