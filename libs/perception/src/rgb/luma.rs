//! RGB → 8-bit luma, the grey image the tracker works on.
//!
//! The weights and rounding are OpenCV's fixed-point BT.601 conversion (`cvtColor` with
//! `COLOR_RGB2GRAY`: `Y = (9798 R + 19235 G + 3735 B + 2^14) >> 15`, checked bit for bit against
//! opencv-python-headless 5.0 on 10^6 random pixels), so the OpenCV oracle of the KLT
//! comparison sees exactly the image our tracker sees.

use image::GrayImage;

const R_WEIGHT: u32 = 9_798;
const G_WEIGHT: u32 = 19_235;
const B_WEIGHT: u32 = 3_735;
const SHIFT: u32 = 15;
const ROUND: u32 = 1 << (SHIFT - 1);

/// Luma of one RGB pixel.
pub fn luma(r: u8, g: u8, b: u8) -> u8 {
    let y = (u32::from(r) * R_WEIGHT + u32::from(g) * G_WEIGHT + u32::from(b) * B_WEIGHT + ROUND)
        >> SHIFT;
    // The weights sum to 2^15, so y ≤ 255.
    y as u8
}

/// Writes the luma of a row-major RGB buffer of `width × height` pixels into `out`, reusing its
/// allocation when the size is unchanged. The caller has checked `rgb.len() == 3 · w · h`.
pub(crate) fn luma_into(rgb: &[u8], width: u32, height: u32, out: &mut GrayImage) {
    debug_assert_eq!(rgb.len(), width as usize * height as usize * 3);
    if out.dimensions() != (width, height) {
        *out = GrayImage::new(width, height);
    }
    let dst: &mut [u8] = out;
    for (y, px) in dst.iter_mut().zip(rgb.chunks_exact(3)) {
        *y = luma(px[0], px[1], px[2]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn luma_matches_opencv_reference_values() {
        // Values from cv2.cvtColor(..., COLOR_RGB2GRAY) (opencv-python-headless 5.0).
        assert_eq!(luma(0, 0, 0), 0);
        assert_eq!(luma(255, 255, 255), 255);
        assert_eq!(luma(255, 0, 0), 76);
        assert_eq!(luma(0, 255, 0), 150);
        assert_eq!(luma(0, 0, 255), 29);
        assert_eq!(luma(110, 128, 150), 125);
    }

    #[test]
    fn luma_into_converts_every_pixel_and_resizes() {
        let mut out = GrayImage::new(1, 1);
        luma_into(
            &[255, 255, 255, 0, 0, 0, 255, 0, 0, 0, 255, 0],
            2,
            2,
            &mut out,
        );
        assert_eq!(out.dimensions(), (2, 2));
        assert_eq!(out.as_raw(), &vec![255, 0, 76, 150]);
    }
}
