//! EVT 3.0 round trip: any time-sorted events of a sensor are read back exactly, at the format's
//! microsecond resolution, across wraps of its 24-bit clock and long silences.

use event_camera::{Event, Polarity};
use event_formats::evt3;
use proptest::prelude::*;

fn events() -> impl Strategy<Value = (u16, u16, Vec<Event>)> {
    (1u16..=2048, 1u16..=2048).prop_flat_map(|(w, h)| {
        let gap = prop_oneof![
            8 => 0u64..5_000_000,             // dense: up to 5 ms
            1 => 0u64..40_000_000_000,        // silences of up to 40 s (≥ two clock wraps)
        ];
        (
            Just(w),
            Just(h),
            prop::collection::vec((gap, 0..w, 0..h, any::<bool>()), 0..300),
        )
            .prop_map(|(w, h, raw)| {
                let mut t = 0u64;
                let events = raw
                    .into_iter()
                    .map(|(gap, x, y, on)| {
                        t += gap;
                        Event {
                            t_ns: t,
                            x,
                            y,
                            polarity: if on { Polarity::On } else { Polarity::Off },
                        }
                    })
                    .collect();
                (w, h, events)
            })
    })
}

proptest! {
    #[test]
    fn written_events_read_back_at_microseconds((w, h, events) in events()) {
        let mut raw = Vec::new();
        evt3::write(&mut raw, w, h, &events).unwrap();
        let decoded = evt3::read(&raw).unwrap();
        prop_assert_eq!(decoded.geometry, Some(evt3::Geometry { width: w, height: h }));
        let want: Vec<Event> = events
            .iter()
            .map(|e| Event { t_ns: e.t_ns / 1000 * 1000, ..*e })
            .collect();
        prop_assert_eq!(decoded.events, want);
    }
}

proptest! {
    /// A stream written in pieces (each a restart point, as ROS 2 event packets are) is, put
    /// together, the same events; and each piece read on its own gives its own events, with times
    /// within the 24-bit wrap a decoder starting there can know.
    #[test]
    fn a_stream_written_in_restartable_pieces_reads_back(
        (w, h, events) in events(),
        cuts in prop::collection::vec(0usize..300, 0..8),
    ) {
        let mut cuts: Vec<usize> = cuts.into_iter().map(|c| c.min(events.len())).collect();
        cuts.push(0);
        cuts.push(events.len());
        cuts.sort_unstable();
        let mut encoder = evt3::StreamEncoder::new(w, h).unwrap();
        let mut whole = encoder.header().into_bytes();
        for piece in cuts.windows(2) {
            encoder.restart();
            let mut bytes = Vec::new();
            encoder.encode(&events[piece[0]..piece[1]], &mut bytes).unwrap();
            whole.extend_from_slice(&bytes);
            // Read with a header: a bare word stream may start with the byte `%`.
            let alone = evt3::read(&[encoder.header().as_bytes(), &bytes].concat()).unwrap();
            let wrap_us = 1u64 << 24;
            let want: Vec<(u64, u16, u16)> = events[piece[0]..piece[1]]
                .iter()
                .map(|e| (e.t_ns / 1000 % wrap_us, e.x, e.y))
                .collect();
            let got: Vec<(u64, u16, u16)> = alone
                .events
                .iter()
                .map(|e| (e.t_ns / 1000 % wrap_us, e.x, e.y))
                .collect();
            prop_assert_eq!(got, want);
        }
        let decoded = evt3::read(&whole).unwrap();
        let want: Vec<Event> = events
            .iter()
            .map(|e| Event { t_ns: e.t_ns / 1000 * 1000, ..*e })
            .collect();
        prop_assert_eq!(decoded.events, want);
    }
}

#[test]
fn a_dense_stream_costs_about_two_bytes_per_event() {
    // 10 000 events per ms across 640 columns of a few rows: one ADDR_X each, shared headers.
    let events: Vec<Event> = (0..100_000u64)
        .map(|k| Event {
            t_ns: k * 100,
            x: (k % 640) as u16,
            y: ((k / 640) % 4) as u16,
            polarity: Polarity::On,
        })
        .collect();
    let mut raw = Vec::new();
    evt3::write(&mut raw, 640, 480, &events).unwrap();
    let per_event = raw.len() as f64 / events.len() as f64;
    assert!(per_event < 2.5, "{per_event} bytes per event");
}
