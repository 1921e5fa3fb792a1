//! The bus's one error type.

use proto::{DecodeError, KeyError};

/// Why a bus operation failed.
#[derive(Debug, thiserror::Error)]
pub enum BusError {
    #[error("invalid Zenoh configuration: {0}")]
    Config(String),
    /// A credentials file or the session's secrets directory is missing, malformed or not
    /// private.
    #[error("credentials: {0}")]
    Credentials(String),
    #[error("zenoh: {what}: {message}")]
    Zenoh { what: String, message: String },
    #[error(transparent)]
    Key(#[from] KeyError),
    #[error("message on {key}: {source}")]
    Decode {
        key: String,
        #[source]
        source: DecodeError,
    },
    #[error("timed out after {waited_s:.1} s waiting for {what}")]
    Timeout { what: String, waited_s: f64 },
}
