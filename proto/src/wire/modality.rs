//! The observers' sensing modality and the receiver that decodes a run: one type each, shared by
//! every process, the case files, the command line and the run directory (`"rgb"`, `"events"`,
//! `"ideal"` wherever they are written).

use serde::{Deserialize, Serialize};

/// The sensor an observer carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Modality {
    /// 25 Hz RGB camera with the KLT receiver.
    Rgb,
    /// 100 Hz renders converted to synthetic events in 40 ms packets.
    Events,
}

impl Modality {
    pub const ALL: [Modality; 2] = [Modality::Rgb, Modality::Events];

    pub fn as_str(self) -> &'static str {
        match self {
            Modality::Rgb => "rgb",
            Modality::Events => "events",
        }
    }

    /// Whether the performer's broadcast starts with the event acquisition preamble.
    pub fn acquisition(self) -> bool {
        matches!(self, Modality::Events)
    }
}

/// What decodes the observers' view in an in-process run: the ideal-message baseline (ground
/// truth projected into each camera, no sensor) or a real receiver on rendered sensor data.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Receiver {
    /// Ground-truth projection (evaluation baseline, no sensor).
    Ideal,
    /// 25 Hz RGB camera with the KLT receiver.
    Rgb,
    /// 100 Hz renders converted to synthetic events in 40 ms packets.
    Events,
}

impl Receiver {
    pub fn as_str(self) -> &'static str {
        match self {
            Receiver::Ideal => "ideal",
            Receiver::Rgb => "rgb",
            Receiver::Events => "events",
        }
    }

    /// The sensor behind the receiver; `None` for the ideal baseline.
    pub fn sensor(self) -> Option<Modality> {
        match self {
            Receiver::Ideal => None,
            Receiver::Rgb => Some(Modality::Rgb),
            Receiver::Events => Some(Modality::Events),
        }
    }
}

impl From<Modality> for Receiver {
    fn from(m: Modality) -> Self {
        match m {
            Modality::Rgb => Receiver::Rgb,
            Modality::Events => Receiver::Events,
        }
    }
}

/// How observer cameras render. `Raster`, the default, is Waggle's own renderer (CPU, no GL, the
/// same bytes on any machine); `Damage` and `Full` are MuJoCo's renderer (the paper's, kept as
/// the reference), by damage rectangles or whole frames, which deliver bit-identical sensor
/// output to each other (`Full` is the reference the damage path is checked against; `mujoco`
/// names `Damage`).
#[derive(
    Debug, Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum RenderPath {
    /// Every render instant rasterises and reads back the whole 640×480 frame.
    Full,
    /// Re-render only the rectangle the moved bodies can cover; skip a render in which nothing
    /// the camera can see changed.
    #[cfg_attr(feature = "clap", value(alias = "mujoco"))]
    Damage,
    /// Waggle's renderer: only the damage rectangle's pixels, only the bodies reaching it, each
    /// at a level of detail for its size.
    #[default]
    Raster,
}

impl RenderPath {
    pub const ALL: [RenderPath; 3] = [RenderPath::Full, RenderPath::Damage, RenderPath::Raster];

    pub fn as_str(self) -> &'static str {
        match self {
            RenderPath::Full => "full",
            RenderPath::Damage => "damage",
            RenderPath::Raster => "raster",
        }
    }

    /// Whether MuJoCo's renderer (EGL) draws this path.
    pub fn is_mujoco(self) -> bool {
        matches!(self, RenderPath::Full | RenderPath::Damage)
    }
}

impl std::str::FromStr for RenderPath {
    type Err = UnknownName;
    fn from_str(s: &str) -> Result<Self, UnknownName> {
        if s == "mujoco" {
            return Ok(RenderPath::Damage);
        }
        parse_name(
            &RenderPath::ALL,
            RenderPath::as_str,
            s,
            "render path",
            "full, damage (or mujoco), raster",
        )
    }
}

impl std::fmt::Display for RenderPath {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// How the scheduler's safety router lets observers fly.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default, Serialize, Deserialize,
)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum FlightMode {
    /// One observer in the air at a time (the paper's rule).
    #[default]
    Sequential,
    /// Trips overlap whenever their reserved space-time paths keep the clearance.
    Concurrent,
}

impl FlightMode {
    pub const ALL: [FlightMode; 2] = [FlightMode::Sequential, FlightMode::Concurrent];

    pub fn as_str(self) -> &'static str {
        match self {
            FlightMode::Sequential => "sequential",
            FlightMode::Concurrent => "concurrent",
        }
    }
}

impl std::str::FromStr for FlightMode {
    type Err = UnknownName;
    fn from_str(s: &str) -> Result<Self, UnknownName> {
        parse_name(
            &FlightMode::ALL,
            FlightMode::as_str,
            s,
            "flight mode",
            "sequential, concurrent",
        )
    }
}

impl std::fmt::Display for FlightMode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The one of `all` named `s`, or an error listing the `expected` names.
pub(crate) fn parse_name<T: Copy>(
    all: &[T],
    name: fn(T) -> &'static str,
    s: &str,
    what: &'static str,
    expected: &'static str,
) -> Result<T, UnknownName> {
    all.iter()
        .copied()
        .find(|&m| name(m) == s)
        .ok_or_else(|| UnknownName {
            what,
            value: s.to_owned(),
            expected,
        })
}

/// A name that is not a modality or receiver.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown {what} {value:?} (expected one of: {expected})")]
pub struct UnknownName {
    pub what: &'static str,
    pub value: String,
    pub expected: &'static str,
}

impl std::str::FromStr for Modality {
    type Err = UnknownName;
    fn from_str(s: &str) -> Result<Self, UnknownName> {
        parse_name(
            &Modality::ALL,
            Modality::as_str,
            s,
            "modality",
            "rgb, events",
        )
    }
}

impl std::str::FromStr for Receiver {
    type Err = UnknownName;
    fn from_str(s: &str) -> Result<Self, UnknownName> {
        parse_name(
            &[Receiver::Ideal, Receiver::Rgb, Receiver::Events],
            Receiver::as_str,
            s,
            "receiver",
            "ideal, rgb, events",
        )
    }
}

impl std::fmt::Display for Modality {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl std::fmt::Display for Receiver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_through_text_and_json() {
        for m in Modality::ALL {
            assert_eq!(m.as_str().parse::<Modality>(), Ok(m));
            assert_eq!(serde_json::to_string(&m).unwrap(), format!("\"{m}\""));
            assert_eq!(Receiver::from(m).sensor(), Some(m));
        }
        assert_eq!("ideal".parse::<Receiver>(), Ok(Receiver::Ideal));
        assert_eq!(Receiver::Ideal.sensor(), None);
        let err = "depth".parse::<Modality>().unwrap_err();
        assert!(err.to_string().contains("\"depth\""), "{err}");
        assert!(Modality::Events.acquisition() && !Modality::Rgb.acquisition());
        for r in RenderPath::ALL {
            assert_eq!(r.as_str().parse::<RenderPath>(), Ok(r));
        }
        assert_eq!(RenderPath::default(), RenderPath::Raster);
        assert!("fast".parse::<RenderPath>().is_err());
    }
}
