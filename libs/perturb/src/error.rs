//! Why a perturbation term, a preset or a whole set of terms was refused: one error type for the
//! crate, each variant naming the term and the value.

/// Why a perturbation term was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PerturbError {
    #[error("unknown perturbation {key:?} (known: {known})")]
    UnknownKey { key: String, known: String },
    #[error("unknown sensor preset {name:?} (known: {known})")]
    UnknownPreset { name: String, known: String },
    #[error("preset file line {line}: {reason}")]
    PresetFileLine { line: usize, reason: String },
    #[error("perturbation {0:?} is not KEY=VALUE (e.g. events.shot_noise_hz=0.5)")]
    NotAnAssignment(String),
    #[error("{0} needs a real-noise source (--real-noise FILE, or a study's real_noise)")]
    RealNoiseWithoutSource(&'static str),
    #[error("the real-noise source fitted × {copies} copies gives {key} = {value}, past its {max}")]
    RealNoiseFitTooLoud {
        key: &'static str,
        value: f64,
        copies: u32,
        max: f64,
    },
    #[error("perturbation {key}: {value:?} is not a number")]
    NotANumber { key: String, value: String },
    #[error("perturbation {key} = {value}: must be {min}–{max} {unit}{whole}")]
    OutOfRange {
        key: String,
        value: f64,
        min: f64,
        max: f64,
        unit: &'static str,
        whole: &'static str,
    },
    #[error(
        "perturbation light.lux = {lux}: the event sensor's background activity would be \
         {shot_hz} Hz per pixel (events.shot_noise_hz = {own_hz} plus darkness's \
         light.dim_shot_hz_lx = {dim_hz_lx} Hz·lx / light.lux), above the {max_hz} Hz per pixel the sensor model takes{least}"
    )]
    TooDark {
        lux: f64,
        own_hz: f64,
        shot_hz: f64,
        dim_hz_lx: f64,
        max_hz: f64,
        /// ": at least … lx with this events.shot_noise_hz", or what to lower instead.
        least: String,
    },
}
