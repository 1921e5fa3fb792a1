//! EVT 3.0 throughput, events per second on one core: reading (the ingest path of
//! `waggle decode --events`; issue 31's target ≥ 20 M events/s) against writing the same stream,
//! in one invocation (the ratio is the figure that travels between machines).
//!
//! Run: `cargo bench -p event-formats --bench evt3`. The stream: 5 M events of a v2e-noisy-like
//! 640×480 sensor (uniform pixels, ≈ 1.7 M events per second of sensor time), each figure the
//! median of 5 repetitions. When `deploy/setup.sh` has unpacked faery's real recordings
//! (`third_party/faery/data`), each is read too (EVT 3.0, EVT 2.0, DAT, AEDAT4 with LZ4), with
//! its read rate beside the synthetic stream's.

use std::hint::black_box;
use std::time::{Duration, Instant};

use event_camera::{Event, Polarity};
use event_formats::{aedat4, dat, evt2, evt3};

const EVENTS: u64 = 5_000_000;
const REPEATS: usize = 5;

fn stream() -> Vec<Event> {
    // A fixed LCG: uniform pixels, ≈ 590 ns apart on average.
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let mut next = || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1);
        state >> 33
    };
    let mut t = 0u64;
    (0..EVENTS)
        .map(|_| {
            t += next() % 1180;
            Event {
                t_ns: t,
                x: (next() % 640) as u16,
                y: (next() % 480) as u16,
                polarity: if next() & 1 == 1 {
                    Polarity::On
                } else {
                    Polarity::Off
                },
            }
        })
        .collect()
}

fn median(mut times: Vec<Duration>) -> Duration {
    times.sort();
    times[times.len() / 2]
}

fn main() {
    let events = stream();
    let mut raw = Vec::new();
    let write = median(
        (0..REPEATS)
            .map(|_| {
                raw.clear();
                let start = Instant::now();
                evt3::write(&mut raw, 640, 480, &events).expect("write");
                start.elapsed()
            })
            .collect(),
    );
    let read = median(
        (0..REPEATS)
            .map(|_| {
                let start = Instant::now();
                let decoded = evt3::read(&raw).expect("read");
                black_box(&decoded);
                start.elapsed()
            })
            .collect(),
    );
    let rate = |d: Duration| EVENTS as f64 / d.as_secs_f64() / 1e6;
    println!(
        "EVT 3.0, {EVENTS} events, {:.2} bytes per event: read {:.1} M events/s, write {:.1} M \
         events/s (read/write time ratio {:.2})",
        raw.len() as f64 / EVENTS as f64,
        rate(read),
        rate(write),
        read.as_secs_f64() / write.as_secs_f64()
    );
    real_files(rate(read));
}

/// Read rates of the real cameras' recordings, as a ratio to the synthetic stream's `synthetic`.
fn real_files(synthetic: f64) {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../third_party/faery/data");
    type Reader = fn(&[u8]) -> usize;
    let readers: [(&str, Reader); 4] = [
        ("evt3.raw", |b| {
            evt3::read(b).expect("evt3.raw").events.len()
        }),
        ("evt2.raw", |b| {
            evt2::read(b).expect("evt2.raw").events.len()
        }),
        ("gen4.dat", |b| dat::read(b).expect("gen4.dat").events.len()),
        ("davis346.aedat4", |b| {
            aedat4::read(b).expect("davis346.aedat4").events.len()
        }),
    ];
    for (name, read) in readers {
        let Ok(bytes) = std::fs::read(dir.join(name)) else {
            println!("{name}: not unpacked (bash deploy/setup.sh), skipped");
            return;
        };
        let mut events = 0;
        let time = median(
            (0..REPEATS)
                .map(|_| {
                    let start = Instant::now();
                    events = black_box(read(&bytes));
                    start.elapsed()
                })
                .collect(),
        );
        let rate = events as f64 / time.as_secs_f64() / 1e6;
        println!(
            "{name}: {events} events, {:.2} bytes per event: read {rate:.1} M events/s \
             ({:.2} of the synthetic EVT 3.0 read rate)",
            bytes.len() as f64 / events as f64,
            rate / synthetic
        );
    }
}
