//! Typed errors of the event receiving chain (settings only: bad packets are counted, not errors).

use proto::segmenter::SegmenterError;

/// Why an event receiver (or one of its parts) could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EventReceiverError {
    #[error("invalid event receiver setting `{setting}`: {reason}")]
    BadSetting {
        setting: &'static str,
        reason: String,
    },
    #[error(transparent)]
    Segmenter(#[from] SegmenterError),
}
