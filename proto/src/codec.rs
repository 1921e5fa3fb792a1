//! The one encode/decode pair every process uses.

use bincode::Options;
use serde::{Serialize, de::DeserializeOwned};

/// Version of the wire format; bumped on any incompatible change to a message.
pub const FORMAT_VERSION: u16 = 1;

/// Largest message we accept; protects decoders from hostile length prefixes.
const MAX_MESSAGE_BYTES: u64 = 256 * 1024 * 1024;

/// Why a byte buffer was not accepted as a message.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum DecodeError {
    #[error("message too short to hold the format version ({len} bytes)")]
    MissingVersion { len: usize },
    #[error("unknown wire format version {found} (this build speaks {FORMAT_VERSION})")]
    UnknownVersion { found: u16 },
    #[error("malformed message body: {0}")]
    Malformed(String),
    #[error("inconsistent message: {0}")]
    Inconsistent(String),
}

/// Messages that can check their own internal consistency after decoding.
pub trait Validate {
    /// Returns a description of the first inconsistency found.
    fn validate(&self) -> Result<(), String>;
}

fn options() -> impl Options {
    bincode::DefaultOptions::new()
        .with_fixint_encoding()
        .with_little_endian()
        .with_limit(MAX_MESSAGE_BYTES)
        .reject_trailing_bytes()
}

/// Encodes a message: 2-byte little-endian format version, then the bincode body.
pub fn encode<T: Serialize>(msg: &T) -> Vec<u8> {
    let mut out = FORMAT_VERSION.to_le_bytes().to_vec();
    options()
        .serialize_into(&mut out, msg)
        .expect("serialising into a Vec cannot fail for plain message structs");
    out
}

/// Decodes and validates a message produced by [`encode`].
pub fn decode<T: DeserializeOwned + Validate>(bytes: &[u8]) -> Result<T, DecodeError> {
    let (version, body) = match bytes {
        [a, b, rest @ ..] => (u16::from_le_bytes([*a, *b]), rest),
        _ => return Err(DecodeError::MissingVersion { len: bytes.len() }),
    };
    if version != FORMAT_VERSION {
        return Err(DecodeError::UnknownVersion { found: version });
    }
    let msg: T = options()
        .deserialize(body)
        .map_err(|e| DecodeError::Malformed(e.to_string()))?;
    msg.validate().map_err(DecodeError::Inconsistent)?;
    Ok(msg)
}
