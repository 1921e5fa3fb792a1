//! Prophesee DAT (`.dat`, `td` files of CD events): the `%` header of `crate::header`
//! (`% Version 2`, `% Width`, `% Height`, …), then, from version 2 on, two bytes — the event
//! type and the event size — then fixed-size little-endian events. A CD event (type `0x0C`, or
//! `0x00` in older files) is 8 bytes: a `u32` µs timestamp, then a `u32` holding x (bits 0–13),
//! y (14–27) and the polarity (28–31, non-zero for ON). Files without a version line are
//! version 1: no type and size bytes, 8-byte events.
//!
//! The 32-bit µs time wraps every 71.6 min; the reader counts a wrap when a timestamp falls by
//! more than half the range (a recording is in time order; a small step back is kept as it is).
//! Times are microseconds: written at `t_ns / 1000`, read at `t_us · 1000`.

use std::io::Write;

use event_camera::{Event, Polarity};

pub use crate::evt3::Geometry;
use crate::input::{EventsError, check_events};

/// Largest coordinate DAT can carry (14 bits).
pub const MAX_COORD: u16 = 0x3FFF;

const CD_TYPE: u8 = 0x0C;
const LEGACY_2D_TYPE: u8 = 0x00;
const EVENT_BYTES: u8 = 8;

/// Why a DAT stream could not be written or read; reading errors name the byte offset.
#[derive(Debug, thiserror::Error)]
pub enum DatError {
    #[error("writing DAT: {0}")]
    Io(#[from] std::io::Error),
    #[error(transparent)]
    Events(#[from] EventsError),
    #[error("sensor {width}×{height}: DAT carries at most 16384×16384")]
    SensorTooLarge { width: u16, height: u16 },
    #[error("header: {0}")]
    Header(String),
    #[error("byte {offset}: {what}")]
    Data { offset: usize, what: String },
}

/// A decoded `.dat` file.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DatRecording {
    pub geometry: Option<Geometry>,
    pub events: Vec<Event>,
}

/// Writes `events` of a `width`×`height` sensor as a version 2 DAT file of CD events.
pub fn write(
    out: &mut impl Write,
    width: u16,
    height: u16,
    events: &[Event],
) -> Result<(), DatError> {
    if width > MAX_COORD + 1 || height > MAX_COORD + 1 {
        return Err(DatError::SensorTooLarge { width, height });
    }
    check_events(events, width, height, 0)?;
    write!(
        out,
        "% Data file containing CD events.\n% Version 2\n% Width {width}\n% Height {height}\n"
    )?;
    let mut buf = Vec::with_capacity(events.len() * 8 + 2);
    buf.extend_from_slice(&[CD_TYPE, EVENT_BYTES]);
    for e in events {
        // The timestamp field is 32 bits: times past 71.6 min wrap, as cameras' files do.
        let t_us = (e.t_ns / 1000) as u32;
        let p = u32::from(e.polarity == Polarity::On);
        let data = u32::from(e.x) | (u32::from(e.y) << 14) | (p << 28);
        buf.extend_from_slice(&t_us.to_le_bytes());
        buf.extend_from_slice(&data.to_le_bytes());
    }
    out.write_all(&buf)?;
    Ok(())
}

/// Reads a DAT file of CD events.
pub fn read(bytes: &[u8]) -> Result<DatRecording, DatError> {
    let h = crate::header::percent_header(bytes).map_err(DatError::Header)?;
    let version = match h.get("Version") {
        None => 1,
        Some(v) => v
            .trim()
            .parse::<u32>()
            .map_err(|_| DatError::Header(format!("`% Version {v}` is not a number")))?,
    };
    let mut at = h.data_at;
    let size = if version >= 2 {
        let [kind, size] = *bytes
            .get(at..at + 2)
            .and_then(|b| <&[u8; 2]>::try_from(b).ok())
            .ok_or_else(|| DatError::Data {
                offset: at,
                what: "truncated: the event type and size bytes are missing".into(),
            })?;
        if kind != CD_TYPE && kind != LEGACY_2D_TYPE {
            return Err(DatError::Data {
                offset: at,
                what: format!("event type {kind:#04x} is not CD events (0x0c)"),
            });
        }
        if size != EVENT_BYTES {
            return Err(DatError::Data {
                offset: at + 1,
                what: format!("CD events of {size} bytes, expected {EVENT_BYTES}"),
            });
        }
        at += 2;
        usize::from(size)
    } else {
        usize::from(EVENT_BYTES)
    };
    let data = &bytes[at..];
    if !data.len().is_multiple_of(size) {
        return Err(DatError::Data {
            offset: bytes.len() - data.len() % size,
            what: format!("truncated: an event is cut short ({size}-byte events)"),
        });
    }
    let geometry = h
        .geometry()
        .map(|(width, height)| Geometry { width, height });
    let mut events = Vec::with_capacity(data.len() / size);
    let (mut last, mut wraps) = (None::<u32>, 0u64);
    for (k, e) in data.chunks_exact(size).enumerate() {
        let t = u32::from_le_bytes([e[0], e[1], e[2], e[3]]);
        let w = u32::from_le_bytes([e[4], e[5], e[6], e[7]]);
        if last.is_some_and(|l| l > t && l - t > u32::MAX / 2) {
            wraps += 1;
        }
        last = Some(t);
        let (x, y) = ((w & 0x3FFF) as u16, ((w >> 14) & 0x3FFF) as u16);
        if let Some(g) = geometry.filter(|g| x >= g.width || y >= g.height) {
            return Err(DatError::Data {
                offset: at + k * size,
                what: format!(
                    "event at ({x}, {y}) is outside the {}×{} sensor",
                    g.width, g.height
                ),
            });
        }
        events.push(Event {
            t_ns: ((wraps << 32) | u64::from(t)) * 1000,
            x,
            y,
            polarity: if w >> 28 != 0 {
                Polarity::On
            } else {
                Polarity::Off
            },
        });
    }
    Ok(DatRecording { geometry, events })
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::test_event as ev;

    #[test]
    fn events_round_trip_and_a_wrap_counts() {
        let events = vec![
            ev(7_000, 0, 0, true),
            ev(4_294_000_000_999, 1279, 719, false),
            ev(4_294_967_296_000 + 5_000, 3, 4, true),
        ];
        let mut bytes = Vec::new();
        write(&mut bytes, 1280, 720, &events).unwrap();
        let back = read(&bytes).unwrap();
        assert_eq!(
            back.geometry,
            Some(Geometry {
                width: 1280,
                height: 720
            })
        );
        assert_eq!(back.events, crate::floored_to_us(&events));
    }

    #[test]
    fn bad_files_name_the_offset() {
        let e = read(b"% Version 2\n").unwrap_err();
        assert!(e.to_string().contains("byte 12"), "{e}");
        let e = read(b"% Version 2\n\x0c\x08\x01\x00\x00\x00\x01").unwrap_err();
        assert!(e.to_string().contains("byte 14"), "{e}");
        let e = read(b"% Version 2\n\x0d\x08").unwrap_err();
        assert!(e.to_string().contains("event type 0x0d"), "{e}");
        let e = read(b"% Width 4\n% Height 4\n\x00\x00\x00\x00\x05\x00\x00\x00").unwrap_err();
        assert!(e.to_string().contains("(5, 0) is outside"), "{e}");
    }
}
