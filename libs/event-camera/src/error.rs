//! Typed errors of the converters, the noise model, the packetiser and the picture codec.

/// Smallest accepted contrast threshold. It bounds the events one pixel can emit per interval
/// (|ΔL| ≤ ln 255 ≈ 5.5, so at most ≈ 5 500 crossings), keeping every level index far from
/// overflow and every packet of sane size.
pub const MIN_THRESHOLD: f64 = 1e-3;

/// Why a converter could not be built or a frame could not be converted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConvertError {
    #[error("contrast threshold must be finite and at least {MIN_THRESHOLD}, got {0}")]
    BadThreshold(f64),
    #[error("sensor size {width}x{height} has no pixels")]
    EmptySensor { width: u16, height: u16 },
    #[error("frame has {got} bytes, expected {want} for a {width}x{height} RGB frame")]
    FrameSize {
        got: usize,
        want: usize,
        width: u16,
        height: u16,
    },
    #[error("frame stamp {stamp_ns} ns is not after the previous frame at {previous_ns} ns")]
    StampNotIncreasing { stamp_ns: u64, previous_ns: u64 },
    #[error(
        "changed region {region:?} (x, y, width, height) reaches outside the {width}×{height} sensor"
    )]
    RegionOutside {
        region: [u16; 4],
        width: u16,
        height: u16,
    },
    #[error("a changed region needs a previous frame: the first frame must be converted whole")]
    RegionBeforeFirstFrame,
    #[error(transparent)]
    Noise(#[from] NoiseError),
}

/// The checks every converter makes, in one place so they name the same errors.
impl ConvertError {
    /// A `width`×`height` sensor with contrast threshold `threshold` can be built.
    pub(crate) fn check_sensor(width: u16, height: u16, threshold: f64) -> Result<(), Self> {
        if !(threshold.is_finite() && threshold >= MIN_THRESHOLD) {
            return Err(Self::BadThreshold(threshold));
        }
        if width == 0 || height == 0 {
            return Err(Self::EmptySensor { width, height });
        }
        Ok(())
    }

    /// `rgb` is a whole `width`×`height` RGB frame.
    pub(crate) fn check_frame(rgb: &[u8], width: u16, height: u16) -> Result<(), Self> {
        let want = 3 * usize::from(width) * usize::from(height);
        if rgb.len() == want {
            Ok(())
        } else {
            Err(Self::FrameSize {
                got: rgb.len(),
                want,
                width,
                height,
            })
        }
    }

    /// `stamp_ns` comes after the previous frame's `previous_ns`.
    pub(crate) fn check_stamp(stamp_ns: u64, previous_ns: u64) -> Result<(), Self> {
        if stamp_ns <= previous_ns {
            return Err(Self::StampNotIncreasing {
                stamp_ns,
                previous_ns,
            });
        }
        Ok(())
    }

    /// A changed `region` lies inside the `width`×`height` sensor.
    pub(crate) fn check_region(
        region: Option<proto::PixelRect>,
        width: u16,
        height: u16,
    ) -> Result<(), Self> {
        match region {
            Some(r) if !r.fits(width, height) => Err(Self::RegionOutside {
                region: [r.x, r.y, r.width, r.height],
                width,
                height,
            }),
            _ => Ok(()),
        }
    }
}

/// Why an [`crate::EventNoise`] is not usable; names the offending field.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NoiseError {
    #[error("event noise `{field}` must be finite and non-negative, got {value}")]
    NotFiniteNonNegative { field: &'static str, value: f64 },
    #[error("event noise `{field}` = {value} exceeds the maximum of {max}")]
    TooLarge {
        field: &'static str,
        value: f64,
        max: f64,
    },
    #[error("event noise `linlog_dn` must be 0 (off) or at least 1, got {0}")]
    LinLogBelowOne(f64),
    #[error(
        "event noise `hot_pixel_hz` must be positive when hot_pixels = {hot_pixels}, got {value}"
    )]
    HotPixelRateNotPositive { hot_pixels: u32, value: f64 },
    #[error("event noise `hot_pixels` = {hot_pixels} exceeds the sensor's {pixels} pixels")]
    TooManyHotPixels { hot_pixels: u32, pixels: usize },
}

/// Why an event camera could not be built or could not accept a render.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CameraError {
    #[error(transparent)]
    Convert(#[from] ConvertError),
    #[error("packet period must be in 1..=u32::MAX ns (event offsets are u32), got {0} ns")]
    BadPacketPeriod(u64),
    #[error("render period must be positive")]
    BadRenderPeriod,
}

/// Why a picture could not be composed, encoded or decoded.
#[derive(Debug, thiserror::Error)]
pub enum PictureError {
    #[error(
        "inset crop {x},{y} {width}x{height} does not fit in a {image_width}x{image_height} image"
    )]
    CropOutside {
        x: u32,
        y: u32,
        width: u32,
        height: u32,
        image_width: u32,
        image_height: u32,
    },
    #[error(
        "magnified inset {width}x{height} does not fit in a {image_width}x{image_height} image"
    )]
    InsetTooLarge {
        width: u32,
        height: u32,
        image_width: u32,
        image_height: u32,
    },
    #[error("inset crop must be non-empty with a magnification of at least 1")]
    EmptyInset,
    #[error("malformed event packet: {0}")]
    MalformedPacket(String),
    #[error("image buffer has {got} bytes, expected {want}")]
    BufferSize { got: usize, want: usize },
    /// PNG encoding or decoding failed (`image` reports which, and why).
    #[error("PNG: {0}")]
    Png(#[from] image::ImageError),
}
