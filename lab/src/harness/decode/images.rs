//! RGB recordings through the RGB receiver: a directory of PNG frames (name order, frame k at
//! `k·10⁹/fps` ns, as `waggle events convert` reads them) or a ROS 2 bag's image topic (each
//! image at its header stamp). Each image is remapped into the reference camera when it is
//! another size or a calibration is given; after the last, the last image is repeated for the
//! tail (a still scene), one frame per 40 ms.

use std::path::Path;

use anyhow::{Context, Result, bail};
use event_camera::picture::decode_png;
use perception::{Perception, SensorInput};
use proto::scene::{IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX};
use proto::{Modality, RgbFrame};

use super::{DecodeOptions, DecodeOut, PACKET_NS, camera};
use crate::harness::decode::convert::{frame_paths, stamp_ns};
use crate::harness::link::observer_out;
use event_camera::calibration::ImageRemap;

/// One image as read: stamp, size and RGB bytes.
pub(crate) struct Image {
    pub(crate) stamp_ns: u64,
    pub(crate) width: u16,
    pub(crate) height: u16,
    pub(crate) rgb: Vec<u8>,
}

/// Whether `path` is a bag rather than a directory of PNG frames.
fn is_bag(path: &Path) -> bool {
    if !path.is_dir() {
        return true;
    }
    path.join("metadata.yaml").is_file()
        || std::fs::read_dir(path).is_ok_and(|mut d| {
            d.any(|e| e.is_ok_and(|e| e.path().extension().is_some_and(|x| x == "mcap")))
        })
}

/// The receiver, fed one image at a time.
pub(crate) struct Feed {
    perception: Perception,
    /// The remap every image goes through, once the first image's size is known.
    remap: Option<Option<ImageRemap>>,
    calibration: Option<std::path::PathBuf>,
    size: Option<(u16, u16)>,
    seq: u64,
    last: Option<Image>,
    tokens: Vec<proto::SegmentToken>,
    frames: Vec<proto::ReleasedFrame>,
}

impl Feed {
    /// The RGB receiver of a camera at `placement`, remapping through `calibration`.
    pub(crate) fn new(
        placement: proto::scene::Placement,
        rectification: proto::Rectification,
        check: proto::FrameCheck,
        calibration: Option<std::path::PathBuf>,
    ) -> Result<Self> {
        let mut perception =
            Perception::for_camera(Modality::Rgb, placement.camera(), rectification)?;
        perception.set_frame_check(check);
        Ok(Self {
            perception,
            remap: None,
            calibration,
            size: None,
            seq: 0,
            last: None,
            tokens: Vec::new(),
            frames: Vec::new(),
        })
    }

    /// Images given to the receiver.
    pub(crate) fn images(&self) -> u64 {
        self.seq
    }

    /// The first image's size, once one has come.
    pub(crate) fn size(&self) -> Option<(u16, u16)> {
        self.size
    }

    /// Whether images are remapped into the reference camera.
    pub(crate) fn remapped(&self) -> bool {
        self.remap.as_ref().is_some_and(Option::is_some)
    }

    /// The tokens confirmed and frames released so far.
    pub(crate) fn tokens_and_frames(&self) -> (&[proto::SegmentToken], &[proto::ReleasedFrame]) {
        (&self.tokens, &self.frames)
    }

    /// The tokens and frames so far.
    pub(crate) fn decoded(&self) -> crate::harness::link::ObserverOut {
        observer_out(&self.tokens, &self.frames)
    }

    /// Holds the last image still for `tail_s` (one frame per 40 ms) and returns the time the
    /// last frame ends, ns; `None` when no image came.
    pub(crate) fn finish(&mut self, tail_s: f64) -> Result<Option<u64>> {
        let Some(last) = self.last.take() else {
            return Ok(None);
        };
        let tail_ns = (tail_s * 1e9).round() as u64;
        let end_ns = last.stamp_ns + tail_ns;
        let mut stamp = last.stamp_ns + PACKET_NS;
        let (width, height, rgb) = (last.width, last.height, last.rgb);
        while stamp <= end_ns {
            let rgb = rgb.clone();
            self.push(Image {
                stamp_ns: stamp,
                width,
                height,
                rgb,
            })?;
            stamp += PACKET_NS;
        }
        Ok(Some(end_ns))
    }

    pub(crate) fn push(&mut self, image: Image) -> Result<()> {
        let size = (image.width, image.height);
        match self.size {
            None => {
                self.size = Some(size);
                let cam = camera(self.calibration.as_ref(), Some(size))?;
                self.remap = Some(cam.as_ref().map(ImageRemap::new));
            }
            Some(first) if first != size => bail!(
                "image {} is {}×{} after {}×{} images",
                self.seq,
                size.0,
                size.1,
                first.0,
                first.1
            ),
            Some(_) => {}
        }
        if let Some(last) = &self.last
            && image.stamp_ns <= last.stamp_ns
        {
            bail!(
                "image {} at {} ns does not follow the previous one at {} ns",
                self.seq,
                image.stamp_ns,
                last.stamp_ns
            );
        }
        let rgb = match self.remap.as_ref().and_then(Option::as_ref) {
            Some(remap) => remap.apply(&image.rgb)?,
            None => image.rgb.clone(),
        };
        let frame = RgbFrame {
            seq: self.seq,
            stamp_ns: image.stamp_ns,
            width: IMAGE_WIDTH_PX,
            height: IMAGE_HEIGHT_PX,
            valid: true,
            continuous: true,
            rgb,
        };
        let step = self.perception.push(SensorInput::Rgb(&frame))?;
        self.tokens.extend(step.tokens);
        self.frames.extend(step.frames);
        self.seq += 1;
        self.last = Some(image);
        Ok(())
    }
}

pub(super) fn decode_images(
    opts: &DecodeOptions,
    path: &Path,
    topic: Option<&str>,
    fps: u32,
) -> Result<DecodeOut> {
    let mut feed = Feed::new(
        opts.placement,
        opts.rectification,
        opts.frame_check,
        opts.calibration.clone(),
    )?;
    let format = if is_bag(path) {
        let bag = ros2_bag::ingest::read_image_bag(
            path,
            topic,
            // O1's camera in a bag of `waggle export ros2`.
            &["/O1/camera/image_raw/compressed", "/O1/camera/image_raw"],
        )
        .with_context(|| format!("reading {}", path.display()))?;
        for image in bag.images() {
            let image = image.with_context(|| format!("decoding {}", path.display()))?;
            feed.push(Image {
                stamp_ns: image.stamp_ns,
                width: image.width,
                height: image.height,
                rgb: image.rgb,
            })?;
        }
        format!("bag {} ({} images)", bag.topic, bag.len())
    } else {
        if topic.is_some() {
            bail!(
                "--topic names a bag's topic; {} is a PNG directory",
                path.display()
            );
        }
        if fps == 0 {
            bail!("--fps must be at least 1");
        }
        for (k, file) in frame_paths(path)?.iter().enumerate() {
            let bytes =
                std::fs::read(file).with_context(|| format!("reading {}", file.display()))?;
            let png = decode_png(&bytes).with_context(|| format!("decoding {}", file.display()))?;
            let (w, h) = (png.width(), png.height());
            let (Ok(width), Ok(height)) = (u16::try_from(w), u16::try_from(h)) else {
                bail!("{}: a {w}×{h} image is too large", file.display());
            };
            feed.push(Image {
                stamp_ns: stamp_ns(k, fps),
                width,
                height,
                rgb: png.into_raw(),
            })?;
        }
        format!("png directory at {fps} Hz")
    };
    let images = feed.seq;
    let Some(end_ns) = feed.finish(opts.tail_s)? else {
        bail!("{}: no images", path.display());
    };
    let (width_px, height_px) = feed.size.unwrap_or((IMAGE_WIDTH_PX, IMAGE_HEIGHT_PX));
    Ok(DecodeOut {
        file: path.display().to_string(),
        format,
        width_px,
        height_px,
        remapped: feed.remapped(),
        events: None,
        events_outside: None,
        images: Some(images),
        packets: feed.seq,
        sim_seconds: end_ns as f64 * 1e-9,
        decoded: feed.decoded(),
    })
}
