//! Errors of the RGB receiver.

use proto::segmenter::SegmenterError;

/// Settings the RGB receiver cannot run with.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RgbReceiverError {
    #[error("invalid RGB receiver setting: {0}")]
    BadConfig(String),
    #[error(transparent)]
    Segmenter(#[from] SegmenterError),
}
