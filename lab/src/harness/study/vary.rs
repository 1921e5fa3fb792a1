//! One condition of a study: a perturbation term (or, in link studies, a viewpoint axis) and
//! the levels it takes.

use serde::{Deserialize, Serialize};

/// The axis of a study.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Vary {
    /// A perturbation term (`events.shot_noise_hz`) or, in link studies, a viewpoint axis.
    pub key: String,
    /// The values it takes, one point each.
    pub levels: Vec<f64>,
}
