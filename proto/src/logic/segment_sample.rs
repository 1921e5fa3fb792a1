//! One receiver step as the [`crate::segmenter`] takes it: a point or none, how far the
//! receiver trusts it, and the receiver's own NULL gate.

/// One receiver step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    pub stamp_ns: u64,
    /// Target position in the image (x right, y down), if the receiver has one.
    pub point_px: Option<[f64; 2]>,
    /// False when the receiver does not trust this measurement (failed tracking, bad packet).
    pub reliable: bool,
    /// The receiver's own extra NULL condition (e.g. the event receiver's tracking lease). A
    /// closed gate defers NULL confirmation; it does not reset the rest.
    pub null_allowed: bool,
}

impl Sample {
    /// A reliable point with the NULL gate open.
    pub fn tracked(stamp_ns: u64, point_px: [f64; 2]) -> Self {
        Self {
            stamp_ns,
            point_px: Some(point_px),
            reliable: true,
            null_allowed: true,
        }
    }

    /// The sample with its point moved by `map`; a point `map` cannot place makes it an
    /// unreliable sample without a point.
    pub fn mapped(self, map: impl FnOnce([f64; 2]) -> Option<[f64; 2]>) -> Self {
        match self.point_px.map(map) {
            None => self,
            Some(Some(q)) => Self {
                point_px: Some(q),
                ..self
            },
            Some(None) => Self {
                point_px: None,
                reliable: false,
                ..self
            },
        }
    }

    /// No usable measurement at this step.
    pub fn lost(stamp_ns: u64) -> Self {
        Self {
            stamp_ns,
            point_px: None,
            reliable: false,
            null_allowed: false,
        }
    }
}
