//! Event-frame pictures as in the paper's sensor-comparison figure, and PNG encode/decode.
//!
//! A packet is drawn on white: blue for ON, red for OFF, the last event at a pixel deciding its
//! colour. An optional inset magnifies a crop (the paper uses identical 80×60 px bounds for the
//! RGB and event views) into a corner while the full field stays visible, with the crop bounds
//! outlined in the full view. The same [`with_inset`] applies to RGB renders so both rows of the
//! figure share geometry.

use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder, ImageFormat, Rgb};
use proto::{EventPacket, Polarity};

use crate::error::PictureError;

pub const ON_COLOUR: [u8; 3] = [0, 0, 255];
pub const OFF_COLOUR: [u8; 3] = [255, 0, 0];
pub const NO_EVENT_COLOUR: [u8; 3] = [255, 255, 255];
pub const OUTLINE_COLOUR: [u8; 3] = [0, 0, 0];

/// The 8-bit RGB image type of every picture: the `image` crate's buffer.
pub use image::RgbImage;

/// An image filled with one colour.
pub fn filled(width: u32, height: u32, colour: [u8; 3]) -> RgbImage {
    RgbImage::from_pixel(width, height, Rgb(colour))
}

/// Wraps a row-major RGB buffer, checking its size.
pub fn from_rgb(width: u32, height: u32, rgb: Vec<u8>) -> Result<RgbImage, PictureError> {
    let want = width as usize * height as usize * 3;
    let got = rgb.len();
    RgbImage::from_raw(width, height, rgb).ok_or(PictureError::BufferSize { got, want })
}

/// The packet as an event frame: ON blue, OFF red, last polarity per pixel, white elsewhere.
pub fn event_frame(packet: &EventPacket) -> Result<RgbImage, PictureError> {
    let n = packet.xs.len();
    if packet.ys.len() != n || packet.on_bits.len() < n.div_ceil(8) {
        return Err(PictureError::MalformedPacket(format!(
            "packet {}: {} xs, {} ys, {} polarity bytes",
            packet.seq,
            n,
            packet.ys.len(),
            packet.on_bits.len()
        )));
    }
    let (w, h) = (u32::from(packet.width), u32::from(packet.height));
    let mut image = filled(w, h, NO_EVENT_COLOUR);
    // Events are in time order, so painting in order leaves the last polarity.
    for i in 0..n {
        let (x, y) = (u32::from(packet.xs[i]), u32::from(packet.ys[i]));
        if x >= w || y >= h {
            return Err(PictureError::MalformedPacket(format!(
                "packet {}: event {i} at ({x}, {y}) outside {w}x{h}",
                packet.seq
            )));
        }
        let colour = match packet.polarity(i) {
            Polarity::On => ON_COLOUR,
            Polarity::Off => OFF_COLOUR,
        };
        image.put_pixel(x, y, Rgb(colour));
    }
    Ok(image)
}

/// Image corner receiving the magnified inset.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Corner {
    TopLeft,
    TopRight,
    BottomLeft,
    BottomRight,
}

/// A crop `(x, y, width, height)` shown magnified `scale` times in `corner`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Inset {
    pub x: u32,
    pub y: u32,
    pub width: u32,
    pub height: u32,
    pub scale: u32,
    pub corner: Corner,
}

/// Gap between the inset and the image edge, pixels.
const INSET_MARGIN_PX: u32 = 6;
/// Border drawn around the magnified inset, pixels.
const INSET_BORDER_PX: u32 = 2;

impl Inset {
    /// The paper's 80×60 px inset centred on (`centre_x`, `centre_y`) (moved inside a 640×480
    /// field if needed), magnified 3× into the top-right corner.
    pub fn paper(centre_x: u32, centre_y: u32) -> Self {
        let (width, height) = (80, 60);
        Self {
            x: centre_x.saturating_sub(width / 2).min(640 - width),
            y: centre_y.saturating_sub(height / 2).min(480 - height),
            width,
            height,
            scale: 3,
            corner: Corner::TopRight,
        }
    }
}

/// `image` with the inset crop outlined and drawn magnified (nearest neighbour) in its corner.
pub fn with_inset(image: &RgbImage, inset: &Inset) -> Result<RgbImage, PictureError> {
    let Inset {
        x,
        y,
        width,
        height,
        scale,
        corner,
    } = *inset;
    if width == 0 || height == 0 || scale == 0 {
        return Err(PictureError::EmptyInset);
    }
    let crop_outside = || PictureError::CropOutside {
        x,
        y,
        width,
        height,
        image_width: image.width(),
        image_height: image.height(),
    };
    let right = x.checked_add(width).ok_or_else(crop_outside)?;
    let bottom = y.checked_add(height).ok_or_else(crop_outside)?;
    if right > image.width() || bottom > image.height() {
        return Err(crop_outside());
    }
    let framed = |len: u32| {
        len.checked_mul(scale)
            .and_then(|l| l.checked_add(2 * INSET_BORDER_PX))
    };
    let (Some(box_w), Some(box_h)) = (framed(width), framed(height)) else {
        return Err(PictureError::EmptyInset);
    };
    if box_w + 2 * INSET_MARGIN_PX > image.width() || box_h + 2 * INSET_MARGIN_PX > image.height() {
        return Err(PictureError::InsetTooLarge {
            width: box_w,
            height: box_h,
            image_width: image.width(),
            image_height: image.height(),
        });
    }
    let mut out = image.clone();
    // Outline just outside the crop (clipped to the image) so the crop's pixels stay visible.
    let (ox0, oy0) = (x.saturating_sub(1), y.saturating_sub(1));
    let (ox1, oy1) = (right.min(image.width() - 1), bottom.min(image.height() - 1));
    for px in ox0..=ox1 {
        out.put_pixel(px, oy0, Rgb(OUTLINE_COLOUR));
        out.put_pixel(px, oy1, Rgb(OUTLINE_COLOUR));
    }
    for py in oy0..=oy1 {
        out.put_pixel(ox0, py, Rgb(OUTLINE_COLOUR));
        out.put_pixel(ox1, py, Rgb(OUTLINE_COLOUR));
    }
    let bx = match corner {
        Corner::TopLeft | Corner::BottomLeft => INSET_MARGIN_PX,
        Corner::TopRight | Corner::BottomRight => image.width() - INSET_MARGIN_PX - box_w,
    };
    let by = match corner {
        Corner::TopLeft | Corner::TopRight => INSET_MARGIN_PX,
        Corner::BottomLeft | Corner::BottomRight => image.height() - INSET_MARGIN_PX - box_h,
    };
    for py in 0..box_h {
        for px in 0..box_w {
            let inside = (INSET_BORDER_PX..box_w - INSET_BORDER_PX).contains(&px)
                && (INSET_BORDER_PX..box_h - INSET_BORDER_PX).contains(&py);
            let colour = if inside {
                // Sample the original image: the outline must not leak into the magnified view.
                image
                    .get_pixel(
                        x + (px - INSET_BORDER_PX) / scale,
                        y + (py - INSET_BORDER_PX) / scale,
                    )
                    .0
            } else {
                OUTLINE_COLOUR
            };
            out.put_pixel(bx + px, by + py, Rgb(colour));
        }
    }
    Ok(out)
}

/// The packet's event frame, with the inset when given.
pub fn event_picture(
    packet: &EventPacket,
    inset: Option<&Inset>,
) -> Result<RgbImage, PictureError> {
    let frame = event_frame(packet)?;
    match inset {
        Some(inset) => with_inset(&frame, inset),
        None => Ok(frame),
    }
}

/// Encodes an 8-bit RGB PNG (the `image` crate's PNG encoder, default settings).
pub fn encode_png(image: &RgbImage) -> Result<Vec<u8>, PictureError> {
    let mut bytes = Vec::new();
    PngEncoder::new(&mut bytes).write_image(
        image.as_raw(),
        image.width(),
        image.height(),
        ExtendedColorType::Rgb8,
    )?;
    Ok(bytes)
}

/// Decodes a PNG into 8-bit RGB with the `image` crate: palette and low bit depths are expanded,
/// 16-bit samples are scaled to 8 bits, gray is replicated to R = G = B and alpha is dropped
/// (renders are opaque).
pub fn decode_png(bytes: &[u8]) -> Result<RgbImage, PictureError> {
    let decoded = image::load_from_memory_with_format(bytes, ImageFormat::Png)?;
    Ok(decoded.into_rgb8())
}
