//! `waggle.EventReceiver` and `waggle.RgbReceiver`: Waggle's own receivers, built exactly as an
//! observer builds them (`camera::chain`), fed from numpy arrays.
//!
//! Each class owns the receiver of its modality and drives it the way `Perception` does, but
//! calls it directly so a refused input can say why (`Step.rejected`). The receiver runs with
//! the GIL released: its input is copied out of Python first, and a packet or frame takes
//! milliseconds other Python threads may use.

use numpy::{PyArrayDescrMethods, PyReadonlyArray3, PyUntypedArray, PyUntypedArrayMethods};
use perception::Perception;
use perception::events::EventReceiver;
use perception::rgb::{FrameRejection, RgbReceiver};
use proto::scene::Placement;
use proto::{Modality, Rectification, RgbFrame};
use pyo3::prelude::*;

use crate::camera;
use crate::errors::{bad_arg, int_arg};
use crate::events::{PacketHeader, PyEventPacket, packet_from_array};
use crate::step::Step;

/// What both receiver classes were built with.
#[derive(Debug, Clone, Copy)]
struct Setup {
    placement: Option<Placement>,
    rectification: Rectification,
}

impl Setup {
    fn parse(
        placement: Option<&Bound<'_, PyAny>>,
        rectification: &str,
        modality: Modality,
    ) -> PyResult<(Self, Perception)> {
        let setup = Self {
            placement: camera::placement(placement)?,
            rectification: camera::rectification(rectification)?,
        };
        let chain = camera::chain(modality, setup.placement.as_ref(), setup.rectification)?;
        Ok((setup, chain))
    }

    fn repr(&self, class: &str) -> String {
        let placement = self.placement.map_or("None".to_owned(), |p| {
            format!("{:?}", camera::placement_tuple(&p))
        });
        format!(
            "{class}(placement={placement}, rectification='{}')",
            self.rectification
        )
    }
}

/// A frame check named as the command line names it.
fn frame_check(check: &str) -> PyResult<proto::FrameCheck> {
    check.parse().map_err(|why: String| bad_arg("check", why))
}

/// Perception built a chain of another modality: a bug here, not the caller's.
fn wrong_chain(chain: &Perception) -> PyErr {
    pyo3::exceptions::PyRuntimeError::new_err(format!(
        "internal: built a {} receiver",
        chain.expects()
    ))
}

/// Waggle's event receiver as the paper configures it: 640×480 sensor, 40 ms packets, each
/// starting where the one before ended.
///
/// `EventReceiver(placement=None, rectification="pitched")`: the receiver of an observer
/// placed at `placement = (home_x_m, home_y_m, home_z_m, yaw_rad, pitch_rad)`, matching the
/// trajectory rectified by `rectification` (`off`, `pitched`, `frontal`), as an observer builds
/// it. Without a placement: the raw trajectory (`frontal` then raises `WaggleError`).
#[pyclass(module = "waggle", name = "EventReceiver")]
pub struct PyEventReceiver {
    setup: Setup,
    receiver: Box<EventReceiver>,
}

impl PyEventReceiver {
    fn step(&mut self, py: Python<'_>, packet: &proto::EventPacket) -> Step {
        let receiver = &mut self.receiver;
        let out = py.detach(|| receiver.push_packet(packet));
        let rejected = out.rejected.map(|reason| match &out.rejection_detail {
            Some(detail) => format!("{}: {detail}", reason.label()),
            None => reason.label().to_owned(),
        });
        Step::new(out.step, out.point_px, rejected)
    }
}

#[pymethods]
impl PyEventReceiver {
    #[new]
    #[pyo3(signature = (placement = None, rectification = "pitched"))]
    fn new(placement: Option<&Bound<'_, PyAny>>, rectification: &str) -> PyResult<Self> {
        let (setup, chain) = Setup::parse(placement, rectification, Modality::Events)?;
        match chain {
            Perception::Events(receiver) => Ok(Self { setup, receiver }),
            other => Err(wrong_chain(&other)),
        }
    }

    /// Feeds the next packet: `events` (an array of `EVENT_DTYPE`, in time order) covering
    /// `(start_ns, end_ns]`, sequence number `seq`.
    #[pyo3(signature = (
        events, start_ns, end_ns, seq, valid = true, continuous = true, width = 640, height = 480
    ))]
    #[expect(clippy::too_many_arguments, reason = "one per Python keyword argument")]
    fn push(
        &mut self,
        py: Python<'_>,
        events: &Bound<'_, PyAny>,
        start_ns: i128,
        end_ns: i128,
        seq: i128,
        valid: bool,
        continuous: bool,
        width: i128,
        height: i128,
    ) -> PyResult<Step> {
        let header =
            PacketHeader::from_args(start_ns, end_ns, seq, valid, continuous, width, height)?;
        let packet = packet_from_array(events, header)?;
        Ok(self.step(py, &packet))
    }

    /// Feeds the next packet, already an `EventPacket`.
    fn push_packet(&mut self, py: Python<'_>, packet: &Bound<'_, PyEventPacket>) -> Step {
        self.step(py, &packet.get().packet)
    }

    /// The packets are known to be missing at `stamp_ns` (publisher gone, a fault): drops the
    /// target and any incomplete frame.
    fn missing(&mut self, stamp_ns: i128) -> PyResult<Step> {
        let stamp_ns = int_arg("stamp_ns", stamp_ns)?;
        Ok(Step::new(
            self.receiver.interrupt(stamp_ns).step,
            None,
            None,
        ))
    }

    /// How far the airframe has turned from its home attitude, from the next packet on.
    fn set_ego_rotation(&mut self, rotation: Option<&Bound<'_, PyAny>>) -> PyResult<()> {
        self.receiver
            .set_ego_rotation(camera::ego_rotation(rotation)?);
        Ok(())
    }

    /// The check the session's frames carry (`none`, `parity`, `crc3`), from the next packet on:
    /// a full-length frame is released only when its check agrees.
    fn set_frame_check(&mut self, check: &str) -> PyResult<()> {
        self.receiver.set_frame_check(frame_check(check)?);
        Ok(())
    }

    /// A new round or reception window: forgets target, partial frame and stream continuity.
    fn reset(&mut self) {
        self.receiver.reset();
    }

    /// What its front ends saw and removed so far, as a trial records them: `events_received`
    /// and `events_removed` (noise front end), `events_removed_ego` (ego-motion front end,
    /// `None` while the airframe never turned).
    fn counts(&self) -> std::collections::BTreeMap<&'static str, Option<u64>> {
        let denoise = self.receiver.denoise_counts();
        let ego = self.receiver.ego_motion_counts();
        std::collections::BTreeMap::from([
            ("events_received", Some(denoise.seen)),
            ("events_removed", Some(denoise.removed)),
            ("events_removed_ego", (ego.seen > 0).then_some(ego.removed)),
        ])
    }

    /// `(home_x_m, home_y_m, home_z_m, yaw_rad, pitch_rad)`, or `None`.
    #[getter]
    fn placement(&self) -> Option<(f64, f64, f64, f64, f64)> {
        self.setup.placement.as_ref().map(camera::placement_tuple)
    }

    /// `off`, `pitched` or `frontal`.
    #[getter]
    fn rectification(&self) -> &'static str {
        self.setup.rectification.as_str()
    }

    fn __repr__(&self) -> String {
        self.setup.repr("EventReceiver")
    }
}

/// Waggle's RGB (KLT) receiver as the paper configures it.
///
/// `RgbReceiver(placement=None, rectification="pitched")`: the receiver of an observer
/// placed at `placement = (home_x_m, home_y_m, home_z_m, yaw_rad, pitch_rad)`, matching the
/// trajectory rectified by `rectification` (`off`, `pitched`, `frontal`), as an observer builds
/// it. Without a placement: the raw trajectory (`frontal` then raises `WaggleError`).
#[pyclass(module = "waggle", name = "RgbReceiver")]
pub struct PyRgbReceiver {
    setup: Setup,
    receiver: Box<RgbReceiver>,
}

fn rejection(reason: FrameRejection, frame: &RgbFrame) -> String {
    match reason {
        FrameRejection::BadSize => format!("bad-size: {}x{}", frame.width, frame.height),
        FrameRejection::TooSmall => format!(
            "too-small: {}x{} is below {}x{}",
            frame.width,
            frame.height,
            perception::rgb::receiver::MIN_FRAME_WIDTH_PX,
            perception::rgb::receiver::MIN_FRAME_HEIGHT_PX
        ),
        FrameRejection::StampNotIncreasing => format!(
            "stamp-not-increasing: {} ns is not after the previous frame",
            frame.stamp_ns
        ),
    }
}

/// The `H×W×3` `uint8` C-contiguous pixels of `frame`, with its width and height.
fn pixels(frame: &Bound<'_, PyAny>) -> PyResult<(Vec<u8>, u16, u16)> {
    let array = frame
        .cast::<PyUntypedArray>()
        .map_err(|_| bad_arg("frame", "expected a numpy array (H, W, 3) of uint8"))?;
    let shape = array.shape();
    let &[h, w, 3] = shape else {
        return Err(bad_arg(
            "frame",
            format!("expected shape (H, W, 3), got {shape:?}"),
        ));
    };
    if !array.dtype().is_equiv_to(&numpy::dtype::<u8>(frame.py())) {
        return Err(bad_arg(
            "frame",
            format!("expected dtype uint8, got {}", array.dtype()),
        ));
    }
    if !array.is_c_contiguous() {
        return Err(bad_arg(
            "frame",
            "the array is not C-contiguous (pass np.ascontiguousarray(frame))",
        ));
    }
    let (Ok(width), Ok(height)) = (u16::try_from(w), u16::try_from(h)) else {
        return Err(bad_arg("frame", format!("{w}x{h} pixels is too large")));
    };
    let array = frame.extract::<PyReadonlyArray3<'_, u8>>()?;
    let rgb = array
        .as_slice()
        .map_err(|e| bad_arg("frame", format!("cannot read its pixels: {e}")))?
        .to_vec();
    Ok((rgb, width, height))
}

#[pymethods]
impl PyRgbReceiver {
    #[new]
    #[pyo3(signature = (placement = None, rectification = "pitched"))]
    fn new(placement: Option<&Bound<'_, PyAny>>, rectification: &str) -> PyResult<Self> {
        let (setup, chain) = Setup::parse(placement, rectification, Modality::Rgb)?;
        match chain {
            Perception::Rgb(receiver) => Ok(Self { setup, receiver }),
            other => Err(wrong_chain(&other)),
        }
    }

    /// Feeds the next frame: `frame` (`H×W×3` `uint8`, C-contiguous) rendered at `stamp_ns`,
    /// sequence number `seq`.
    #[pyo3(signature = (frame, stamp_ns, seq, valid = true, continuous = true))]
    fn push(
        &mut self,
        py: Python<'_>,
        frame: &Bound<'_, PyAny>,
        stamp_ns: i128,
        seq: i128,
        valid: bool,
        continuous: bool,
    ) -> PyResult<Step> {
        let stamp_ns = int_arg("stamp_ns", stamp_ns)?;
        let seq = int_arg("seq", seq)?;
        let (rgb, width, height) = pixels(frame)?;
        let frame = RgbFrame {
            seq,
            stamp_ns,
            width,
            height,
            valid,
            continuous,
            rgb,
        };
        let receiver = &mut self.receiver;
        let out = py.detach(|| receiver.push_frame(&frame));
        let point_px = out.track.and_then(|t| t.point_px);
        let rejected = out.rejected.map(|r| rejection(r, &frame));
        Ok(Step::new(out.step, point_px, rejected))
    }

    /// The frames are known to be missing at `stamp_ns` (publisher gone, a fault): drops the
    /// target and any incomplete frame.
    fn missing(&mut self, stamp_ns: i128) -> PyResult<Step> {
        let stamp_ns = int_arg("stamp_ns", stamp_ns)?;
        Ok(Step::new(
            self.receiver.interrupt(stamp_ns).step,
            None,
            None,
        ))
    }

    /// How far the airframe has turned from its home attitude, from the next frame on.
    fn set_ego_rotation(&mut self, rotation: Option<&Bound<'_, PyAny>>) -> PyResult<()> {
        self.receiver
            .set_ego_rotation(camera::ego_rotation(rotation)?);
        Ok(())
    }

    /// The check the session's frames carry (`none`, `parity`, `crc3`), from the next frame on:
    /// a full-length frame is released only when its check agrees.
    fn set_frame_check(&mut self, check: &str) -> PyResult<()> {
        self.receiver.set_frame_check(frame_check(check)?);
        Ok(())
    }

    /// A new round or reception window: forgets target, partial frame and stream continuity.
    fn reset(&mut self) {
        self.receiver.reset();
    }

    /// `(home_x_m, home_y_m, home_z_m, yaw_rad, pitch_rad)`, or `None`.
    #[getter]
    fn placement(&self) -> Option<(f64, f64, f64, f64, f64)> {
        self.setup.placement.as_ref().map(camera::placement_tuple)
    }

    /// `off`, `pitched` or `frontal`.
    #[getter]
    fn rectification(&self) -> &'static str {
        self.setup.rectification.as_str()
    }

    fn __repr__(&self) -> String {
        self.setup.repr("RgbReceiver")
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyEventReceiver>()?;
    m.add_class::<PyRgbReceiver>()
}
