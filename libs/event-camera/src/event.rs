//! One synthetic event and the crossing-time rule shared by the specification.

pub use proto::Polarity;

/// One threshold crossing at one pixel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Event {
    /// Sim time of the crossing, nanoseconds.
    pub t_ns: u64,
    pub x: u16,
    pub y: u16,
    pub polarity: Polarity,
}

/// Default contrast threshold C of the paper.
pub const DEFAULT_THRESHOLD: f64 = 0.18;
