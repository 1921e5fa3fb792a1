//! `waggle.Step`: what one input (or one known gap) did to a receiver, as plain Python values.
//!
//! Tokens and frames are spelled as the plug-in protocol spells them (`waggle.plugin`): a token
//! is `(NAME, stamp_ns)` with NAME upper case, a frame `(payload, [17 token stamps])`, so a
//! plug-in at any level can hand on what Waggle's own receiver returned.

use proto::DecodeStep;
use pyo3::prelude::*;

/// What one input did: tokens confirmed and frames released by it, where the receiver placed
/// the target, and why the input was refused if it was.
#[pyclass(frozen, eq, module = "waggle", name = "Step")]
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Step {
    /// `(NAME, stamp_ns)`, NAME one of NULL START BIT0 BIT1 END UNKNOWN, in order.
    #[pyo3(get)]
    pub tokens: Vec<(String, u64)>,
    /// `(payload, token_stamps_ns)`: payload 0…63 (b1 most significant), its 17 token stamps.
    #[pyo3(get)]
    pub frames: Vec<(u8, Vec<u64>)>,
    /// The image position fed to the segmenter for this input, `None` without a target.
    #[pyo3(get)]
    pub point_px: Option<(f64, f64)>,
    /// Why the receiver refused the input (`None`: it was used).
    #[pyo3(get)]
    pub rejected: Option<String>,
}

impl Step {
    pub fn new(step: DecodeStep, point_px: Option<[f64; 2]>, rejected: Option<String>) -> Self {
        Self {
            tokens: step
                .tokens
                .iter()
                .map(|t| (format!("{:?}", t.token).to_uppercase(), t.stamp_ns))
                .collect(),
            frames: step
                .frames
                .into_iter()
                .map(|f| (f.payload, f.token_stamps_ns))
                .collect(),
            point_px: point_px.map(|[x, y]| (x, y)),
            rejected,
        }
    }
}

#[pymethods]
impl Step {
    fn __repr__(&self) -> String {
        let tokens: Vec<String> = self
            .tokens
            .iter()
            .map(|(name, stamp)| format!("('{name}', {stamp})"))
            .collect();
        let frames: Vec<String> = self
            .frames
            .iter()
            .map(|(payload, stamps)| format!("({payload}, {stamps:?})"))
            .collect();
        let point = self
            .point_px
            .map_or("None".to_owned(), |(x, y)| format!("({x:?}, {y:?})"));
        let rejected = self
            .rejected
            .as_ref()
            .map_or("None".to_owned(), |r| format!("{r:?}"));
        format!(
            "Step(tokens=[{}], frames=[{}], point_px={point}, rejected={rejected})",
            tokens.join(", "),
            frames.join(", ")
        )
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Step>()
}
