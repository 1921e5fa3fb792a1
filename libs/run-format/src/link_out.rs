//! What a receiver decoded on a link, as `waggle link --json` prints it and as the lab keeps it:
//! confirmed tokens, released frames, payloads. The render cache stores the ideal receivers'
//! decodes in this shape and trial records name lost tokens with it, so the lab, the cache
//! entries and the fuzz targets share one type per concept.

use serde::{Deserialize, Serialize};

/// One confirmed token and when it was confirmed, sim s.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TokenOut {
    pub token: String,
    pub t_s: f64,
}

/// One released frame and when its final NULL was confirmed, sim s.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrameOut {
    pub payload: String,
    pub final_null_s: f64,
}

/// One observer's decodes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObserverOut {
    pub payloads: Vec<String>,
    pub frames: Vec<FrameOut>,
    pub tokens: Vec<TokenOut>,
}
