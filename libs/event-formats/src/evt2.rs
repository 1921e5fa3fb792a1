//! Prophesee EVT 2.0 (`.raw`, the Gen3 and Gen4 cameras' format): the `%` header of
//! `crate::header` (`% evt 2.0`, or `% format EVT2;…`), then little-endian 32-bit words whose
//! top four bits give their type (Prophesee's "EVT 2.0 format" documentation, Metavision SDK):
//!
//! | type | word | payload |
//! | --- | --- | --- |
//! | 0x0, 0x1 | `CD_OFF`, `CD_ON` | time low 6 bits (27–22), x (21–11), y (10–0) |
//! | 0x8 | `EVT_TIME_HIGH` | time bits 33–6 (27–0) |
//! | 0xA | `EXT_TRIGGER` | time low 6 bits (27–22), channel (12–8), value (0) |
//! | 0xE, 0xF | `OTHERS`, `CONTINUED` | skipped |
//!
//! The 34-bit µs time wraps every 4.77 h; the reader counts wraps (a high part smaller than the
//! last), as for EVT 3.0. Times are microseconds: written at `t_ns / 1000`, read at `t_us · 1000`.
//! The writer emits a `TIME_HIGH` whenever the high part changes, then one word per event.

use std::io::Write;

use event_camera::{Event, Polarity};

pub use crate::evt3::{Geometry, RawRecording, Trigger};
use crate::input::{EventsError, check_events};

/// Largest coordinate EVT 2.0 can carry (11 bits).
pub const MAX_COORD: u16 = 2047;

const CD_OFF: u32 = 0x0;
const CD_ON: u32 = 0x1;
const TIME_HIGH: u32 = 0x8;
const EXT_TRIGGER: u32 = 0xA;

/// Why an EVT 2.0 stream could not be written or read; reading errors name the byte offset.
#[derive(Debug, thiserror::Error)]
pub enum Evt2Error {
    #[error("writing EVT 2.0: {0}")]
    Io(#[from] std::io::Error),
    #[error(transparent)]
    Events(#[from] EventsError),
    #[error("sensor {width}×{height}: EVT 2.0 carries at most 2048×2048")]
    SensorTooLarge { width: u16, height: u16 },
    #[error("header: {0}")]
    Header(String),
    #[error("byte {offset}: {what}")]
    Data { offset: usize, what: String },
}

/// True when the `%` header at the start of `bytes` says EVT 2.0.
pub fn is_evt2(bytes: &[u8]) -> bool {
    crate::header::percent_header(bytes).is_ok_and(|h| {
        h.get("evt") == Some("2.0") || h.get("format").is_some_and(|f| f.starts_with("EVT2"))
    })
}

/// Writes `events` of a `width`×`height` sensor as an EVT 2.0 `.raw` file.
pub fn write(
    out: &mut impl Write,
    width: u16,
    height: u16,
    events: &[Event],
) -> Result<(), Evt2Error> {
    if width > MAX_COORD + 1 || height > MAX_COORD + 1 {
        return Err(Evt2Error::SensorTooLarge { width, height });
    }
    check_events(events, width, height, 0)?;
    write!(
        out,
        "% evt 2.0\n% format EVT2;height={height};width={width}\n% geometry {width}x{height}\n% end\n"
    )?;
    let mut buf = Vec::with_capacity(events.len() * 4 + 64);
    let time_high = |h: u64, buf: &mut Vec<u8>| {
        buf.extend_from_slice(&((TIME_HIGH << 28) | h as u32).to_le_bytes());
    };
    // The last time-high written and the wraps of its 28 bits a reader has counted so far.
    let (mut high, mut wraps) = (None, 0u64);
    for e in events {
        let t_us = e.t_ns / 1000;
        let h = (t_us >> 6) & 0x0FFF_FFFF;
        let wrap = t_us >> 34;
        // A reader counts a wrap at each time-high below the one before: a later high that is
        // lower counts one by itself; any other wrap is marked by the highest, then the lowest
        // time-high, so times past 2³⁴ µs (4.8 h) read back whole.
        if wrap > wraps && !(wrap - wraps == 1 && high.is_some_and(|last| h < last)) {
            while wraps < wrap {
                time_high(0x0FFF_FFFF, &mut buf);
                time_high(0, &mut buf);
                wraps += 1;
            }
            high = Some(0);
        }
        wraps = wrap;
        if high != Some(h) {
            time_high(h, &mut buf);
            high = Some(h);
        }
        let kind = if e.polarity == Polarity::On {
            CD_ON
        } else {
            CD_OFF
        };
        let w =
            (kind << 28) | (((t_us & 0x3F) as u32) << 22) | (u32::from(e.x) << 11) | u32::from(e.y);
        buf.extend_from_slice(&w.to_le_bytes());
    }
    out.write_all(&buf)?;
    Ok(())
}

/// Reads an EVT 2.0 stream (header optional). An event before the first `TIME_HIGH` has no
/// time: it is an error, as is a word cut short.
pub fn read(bytes: &[u8]) -> Result<RawRecording, Evt2Error> {
    let h = crate::header::percent_header(bytes).map_err(Evt2Error::Header)?;
    let declared = (h.get("evt"), h.get("format"));
    if declared != (None, None) && !is_evt2(bytes) {
        return Err(Evt2Error::Header("not an EVT 2.0 stream (`% evt`)".into()));
    }
    let mut out = RawRecording {
        geometry: h
            .geometry()
            .map(|(width, height)| Geometry { width, height }),
        ..RawRecording::default()
    };
    let data = &bytes[h.data_at..];
    if !data.len().is_multiple_of(4) {
        return Err(Evt2Error::Data {
            offset: bytes.len() - data.len() % 4,
            what: "truncated: a 32-bit word is cut short".into(),
        });
    }
    out.events.reserve(data.len() / 4);
    let (mut high, mut wraps) = (None::<u64>, 0u64);
    for (k, word) in data.chunks_exact(4).enumerate() {
        let offset = h.data_at + 4 * k;
        let w = u32::from_le_bytes([word[0], word[1], word[2], word[3]]);
        let kind = w >> 28;
        let time = |high: Option<u64>| {
            high.map(|h| (wraps << 34) | (h << 6) | u64::from((w >> 22) & 0x3F))
                .ok_or_else(|| Evt2Error::Data {
                    offset,
                    what: "event before the first EVT_TIME_HIGH".into(),
                })
        };
        match kind {
            CD_OFF | CD_ON => {
                let t_us = time(high)?;
                out.events.push(Event {
                    t_ns: t_us * 1000,
                    x: ((w >> 11) & 0x7FF) as u16,
                    y: (w & 0x7FF) as u16,
                    polarity: if kind == CD_ON {
                        Polarity::On
                    } else {
                        Polarity::Off
                    },
                });
            }
            TIME_HIGH => {
                let h = u64::from(w & 0x0FFF_FFFF);
                if high.is_some_and(|last| h < last) {
                    wraps += 1;
                }
                high = Some(h);
            }
            EXT_TRIGGER => out.triggers.push(Trigger {
                t_us: time(high)?,
                channel: ((w >> 8) & 0x1F) as u8,
                rising: w & 1 != 0,
            }),
            _ => {}
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::test_event as ev;

    #[test]
    fn events_round_trip_at_microsecond_resolution() {
        let events = vec![
            ev(1_000, 0, 0, true),
            ev(64_999, 639, 479, false),
            ev(5_000_000_123, 2, 3, true),
        ];
        let mut bytes = Vec::new();
        write(&mut bytes, 640, 480, &events).unwrap();
        assert!(is_evt2(&bytes));
        let back = read(&bytes).unwrap();
        assert_eq!(
            back.geometry,
            Some(Geometry {
                width: 640,
                height: 480
            })
        );
        assert_eq!(back.events, crate::floored_to_us(&events));
    }

    #[test]
    fn bad_streams_name_the_offset() {
        let e = read(b"% evt 2.0\n% end\n\x00\x00\x00\x10").unwrap_err();
        assert!(e.to_string().contains("byte 16"), "{e}");
        let e = read(b"% evt 2.0\n\x00\x00\x00\x80\x01\x02").unwrap_err();
        assert!(e.to_string().contains("byte 14"), "{e}");
        assert!(read(b"% evt 3.0\n% end\n").is_err());
        assert!(write(&mut Vec::new(), 4, 4, &[ev(0, 4, 0, true)]).is_err());
    }

    #[test]
    fn times_past_the_28_bit_time_high_read_back_whole() {
        // The first event already past one wrap, then a jump over two more.
        let wrap_ns = (1u64 << 34) * 1000;
        let events = vec![
            crate::test_event(wrap_ns + 5_000, 1, 2, true),
            crate::test_event(wrap_ns + 9_000, 3, 4, false),
            crate::test_event(3 * wrap_ns + 7_000, 5, 6, true),
        ];
        let mut bytes = Vec::new();
        write(&mut bytes, 8, 8, &events).unwrap();
        assert_eq!(read(&bytes).unwrap().events, events);
    }
}
