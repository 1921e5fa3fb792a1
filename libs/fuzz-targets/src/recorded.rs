//! Session recordings (`libs/recording`): the MCAP reader that replay and audit use.
//!
//! The bytes are read as a recording file ([`recording::read_recording_from`], the reader
//! behind `waggle replay` and `waggle audit`); every raw message is decoded as its schema's
//! type, as replay does. The outcome must account for what was handed out: its message count
//! is the messages visited, and a recording is complete exactly when no problem is named.

use std::io::Cursor;

use recording::{MessageKind, RAW_ENCODING, ReadError, read_recording_from};

/// A recording file's bytes.
pub fn recording(data: &[u8]) {
    let mut visited = 0u64;
    let outcome = read_recording_from::<ReadError>(Cursor::new(data), "fuzz input", |m| {
        visited += 1;
        assert!(m.data.len() <= data.len(), "a message larger than the file");
        if m.message_encoding == RAW_ENCODING
            && let Some(kind) = MessageKind::from_schema_name(m.schema)
            && let Ok(decoded) = recording::decode(kind, m.data)
        {
            let _ = decoded.sim_time_ns();
        }
        Ok(())
    });
    let Ok(outcome) = outcome else { return };
    assert_eq!(outcome.messages, visited);
    assert_eq!(outcome.complete, outcome.problem.is_none());
    if outcome.complete {
        assert!(outcome.damaged.is_empty());
        assert_ne!(outcome.data_crc_ok, Some(false));
    }
    for d in &outcome.damaged {
        assert!(
            d.from_byte <= d.to_byte && d.to_byte <= data.len() as u64,
            "damage {d:?} outside the {} bytes",
            data.len()
        );
    }
}
