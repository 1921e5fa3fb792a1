//! PNG writing for rendered frames.

use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

/// Why a PNG could not be written.
#[derive(Debug, thiserror::Error)]
pub enum PngError {
    #[error("{0}")]
    Io(#[from] std::io::Error),
    #[error("{0}")]
    Encode(#[from] png::EncodingError),
    #[error("buffer of {len} bytes does not hold a {width}x{height} RGB image")]
    Size { len: usize, width: u16, height: u16 },
}

/// Writes row-major RGB8 (top row first) as a PNG file.
pub fn write_rgb_png(path: &Path, rgb: &[u8], width: u16, height: u16) -> Result<(), PngError> {
    if rgb.len() != usize::from(width) * usize::from(height) * 3 {
        return Err(PngError::Size {
            len: rgb.len(),
            width,
            height,
        });
    }
    let mut encoder = png::Encoder::new(
        BufWriter::new(File::create(path)?),
        u32::from(width),
        u32::from(height),
    );
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header()?;
    writer.write_image_data(rgb)?;
    writer.finish()?;
    Ok(())
}
