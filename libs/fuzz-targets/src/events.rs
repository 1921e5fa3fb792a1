//! Event-camera files (`libs/event-formats`): EVT 3.0 and EVT 2.0 `.raw`, DAT and AEDAT4.
//!
//! Each reader gets the fuzzer's bytes. What a reader accepts, its own writer must be able to
//! write back (when the events meet the writer's precondition: on the sensor, in time order),
//! and reading that again must give the same events. [`evt3`] also checks that the word stream
//! decoded in two pieces gives what it gives in one (ROS 2 packets are such pieces), and
//! [`event_writers`] goes the other way: events built from the bytes ([`arbitrary`]) written in
//! every format and read back.

use arbitrary::{Arbitrary, Unstructured};
use event_camera::{Event, Polarity};
use event_formats::aedat4::{Compression, WriteOptions};
use event_formats::evt3::{Geometry, StreamDecoder};

/// The sensor the events of a file fit: its stated geometry, else the smallest holding them.
fn sensor(geometry: Option<Geometry>, events: &[Event]) -> (u16, u16) {
    geometry.map_or_else(
        || {
            let w = events.iter().map(|e| e.x).max().unwrap_or(0);
            let h = events.iter().map(|e| e.y).max().unwrap_or(0);
            (w.saturating_add(1), h.saturating_add(1))
        },
        |g| (g.width, g.height),
    )
}

/// Asserts that `again` (the events written and read back) are `events`.
fn same_events(format: &str, events: &[Event], again: &[Event]) {
    assert_eq!(
        again.len(),
        events.len(),
        "{format}: {} events read back from {} written",
        again.len(),
        events.len()
    );
    if let Some(k) = (0..events.len()).find(|&k| events[k] != again[k]) {
        panic!(
            "{format}: event {k} written as {:?}, read back as {:?}",
            events[k], again[k]
        );
    }
}

/// EVT 3.0 `.raw`: read, the words again in two pieces, write back, read again.
pub fn evt3(data: &[u8]) {
    use event_formats::evt3::{read, write};
    if data.first() != Some(&b'%') && data.len() >= 2 {
        // No header: the whole input is a word stream; cut it at a word boundary.
        let cut = (usize::from(data[0]) * 2).min(data.len() / 2 * 2);
        let (mut whole, mut whole_t) = (Vec::new(), Vec::new());
        let one = StreamDecoder::new().decode(data, 0, &mut whole, &mut whole_t);
        let (mut parts, mut parts_t) = (Vec::new(), Vec::new());
        let mut d = StreamDecoder::new();
        let two = d
            .decode(&data[..cut], 0, &mut parts, &mut parts_t)
            .and_then(|()| d.decode(&data[cut..], cut, &mut parts, &mut parts_t));
        assert_eq!(one.is_ok(), two.is_ok(), "one piece: {one:?}, two: {two:?}");
        if one.is_ok() {
            assert_eq!(whole, parts);
            assert_eq!(whole_t, parts_t);
        }
    }
    let Ok(rec) = read(data) else { return };
    let (w, h) = sensor(rec.geometry, &rec.events);
    let mut out = Vec::new();
    if write(&mut out, w, h, &rec.events).is_ok() {
        let again = read(&out).expect("EVT 3.0 that Waggle wrote reads back");
        same_events("EVT 3.0", &rec.events, &again.events);
        assert_eq!(
            again.geometry,
            Some(Geometry {
                width: w,
                height: h
            })
        );
    }
}

/// EVT 2.0 `.raw`: read, write back, read again.
pub fn evt2(data: &[u8]) {
    use event_formats::evt2::{read, write};
    let Ok(rec) = read(data) else { return };
    rewrite(
        "EVT 2.0",
        sensor(rec.geometry, &rec.events),
        &rec.events,
        |out, w, h, events| write(out, w, h, events).is_ok(),
        |bytes| read(bytes).map(|r| r.events).map_err(|e| e.to_string()),
    );
}

/// DAT: read, write back, read again.
pub fn dat(data: &[u8]) {
    use event_formats::dat::{read, write};
    let Ok(rec) = read(data) else { return };
    rewrite(
        "DAT",
        sensor(rec.geometry, &rec.events),
        &rec.events,
        |out, w, h, events| write(out, w, h, events).is_ok(),
        |bytes| read(bytes).map(|r| r.events).map_err(|e| e.to_string()),
    );
}

/// Writes `events` back as `format` on a `w`×`h` sensor; what Waggle wrote must read back
/// (`read`) as the same events. A refused write (events the format cannot hold) ends the check.
fn rewrite(
    format: &str,
    (w, h): (u16, u16),
    events: &[Event],
    write: impl FnOnce(&mut Vec<u8>, u16, u16, &[Event]) -> bool,
    read: impl FnOnce(&[u8]) -> Result<Vec<Event>, String>,
) {
    let mut out = Vec::new();
    if write(&mut out, w, h, events) {
        let again = read(&out)
            .unwrap_or_else(|e| panic!("{format} that Waggle wrote does not read back: {e}"));
        same_events(format, events, &again);
    }
}

/// AEDAT4: read, write back with the file's compression, read again.
pub fn aedat4(data: &[u8]) {
    use event_formats::aedat4::{read, write};
    let Ok(rec) = read(data) else { return };
    assert!(rec.packets > 0 || rec.events.is_empty());
    let (w, h) = sensor(rec.geometry, &rec.events);
    let opts = WriteOptions {
        compression: writable(rec.compression),
        events_per_packet: 64,
    };
    let mut out = Vec::new();
    if write(&mut out, w, h, &rec.events, &opts).is_ok() {
        let again = read(&out).expect("AEDAT4 that Waggle wrote reads back");
        same_events("AEDAT4", &rec.events, &again.events);
        assert_eq!(again.compression, opts.compression);
    }
}

/// The compression the round trips write: Zstd's high level is written at its default level.
/// Its optimal parser (zstd's C code, levels 13 and up) trips AddressSanitizer's
/// use-after-scope check under cargo-fuzz on a static table, a report that is spurious.
fn writable(c: Compression) -> Compression {
    if c == Compression::ZstdHigh {
        Compression::Zstd
    } else {
        c
    }
}

/// Events a fuzzer builds: a sensor and steps in time and place.
#[derive(Debug, Arbitrary)]
struct EventsInput {
    width: u16,
    height: u16,
    compression: u8,
    /// `(µs since the previous event, x, y, on)`.
    steps: Vec<(u16, u16, u16, bool)>,
}

/// Events from the bytes, written in every format and read back: the same events (at whole
/// microseconds), or a writer's error for a sensor the format cannot carry.
pub fn event_writers(data: &[u8]) {
    let Ok(input) = EventsInput::arbitrary_take_rest(Unstructured::new(data)) else {
        return;
    };
    let (w, h) = (input.width.clamp(1, 4096), input.height.clamp(1, 4096));
    let mut t_us = 0u64;
    let events: Vec<Event> = input
        .steps
        .iter()
        .map(|&(dt, x, y, on)| {
            t_us += u64::from(dt);
            Event {
                t_ns: t_us * 1000,
                x: x % w,
                y: y % h,
                polarity: if on { Polarity::On } else { Polarity::Off },
            }
        })
        .collect();
    let mut out = Vec::new();
    if event_formats::evt3::write(&mut out, w, h, &events).is_ok() {
        let back = event_formats::evt3::read(&out).expect("EVT 3.0 reads back");
        same_events("EVT 3.0", &events, &back.events);
    } else {
        assert!(w > 2048 || h > 2048, "EVT 3.0 refused a {w}×{h} sensor");
    }
    out.clear();
    if event_formats::evt2::write(&mut out, w, h, &events).is_ok() {
        let back = event_formats::evt2::read(&out).expect("EVT 2.0 reads back");
        same_events("EVT 2.0", &events, &back.events);
    } else {
        assert!(w > 2048 || h > 2048, "EVT 2.0 refused a {w}×{h} sensor");
    }
    out.clear();
    event_formats::dat::write(&mut out, w, h, &events).expect("DAT carries 4096×4096");
    let back = event_formats::dat::read(&out).expect("DAT reads back");
    same_events("DAT", &events, &back.events);
    out.clear();
    let compression = writable(Compression::ALL[usize::from(input.compression) % 5]);
    let opts = WriteOptions {
        compression,
        events_per_packet: 1 + usize::from(input.compression % 16),
    };
    event_formats::aedat4::write(&mut out, w, h, &events, &opts).expect("AEDAT4 carries these");
    let back = event_formats::aedat4::read(&out).expect("AEDAT4 reads back");
    same_events("AEDAT4", &events, &back.events);
}
