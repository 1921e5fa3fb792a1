//! Event receiver cost per 40 ms packet (µs), at typical and at peak event counts.
//!
//! Run: `cargo bench -p perception --bench event_receiver`. Each benchmark replays a cycle of
//! packets through one long-lived receiver in steady state (buffers grown, tracking): every
//! measured call is one `EventReceiver::push_packet`; between calls only the sequence number and
//! watermarks are rewritten in place so the replayed stream stays continuous. Reported time is
//! per packet (the mean over the cycle).
//!
//! Packets come from the real converter (`event-camera`) on frames drawn in code:
//! * `typical` — `event_camera::synthetic::MovingBlobScene` (textured background, a 60 px blob
//!   sweeping ±128 px): one 2 s sweep, 50 packets of 1.7–7.3 k events.
//! * `peak_broad` — the same background shifted 2 px per render (the observer itself moving):
//!   ≈ 40 k events per packet all over the sensor, the broad-activity path.
//! * `peak_local` — 32 k events all inside the local tracking window (balanced polarity), the
//!   most expensive path (every event gathered, deduplicated and sorted); drawn directly, as no
//!   rendered scene puts that many events near one target.
//! * `quiet` — an empty packet while tracking (most packets of a mission).

use std::hint::black_box;
use std::time::Instant;

use criterion::{Criterion, criterion_group, criterion_main};
use event_camera::synthetic::MovingBlobScene;
use event_camera::{CameraConfig, EventCamera};
use perception::events::{EventReceiver, EventReceiverConfig};
use proto::{EventPacket, Polarity};

const W: u16 = 640;
const H: u16 = 480;
const RENDER_NS: u64 = 10_000_000;
const PACKET_NS: u64 = 40_000_000;

fn convert(frames: impl Iterator<Item = Vec<u8>>) -> Vec<EventPacket> {
    let mut camera = EventCamera::new(CameraConfig::paper(W, H)).expect("paper camera");
    let mut packets = Vec::new();
    for (k, rgb) in frames.enumerate() {
        packets.extend(
            camera
                .push_frame(k as u64 * RENDER_NS, &rgb)
                .expect("frame size"),
        );
    }
    packets
}

/// Replays `cycle` (renumbered to stay one continuous stream) through one receiver; the
/// reported time is per packet.
fn bench_cycle(
    c: &mut Criterion,
    name: &str,
    warm_up: &[EventPacket],
    mut cycle: Vec<EventPacket>,
) {
    let mut rx = EventReceiver::new(EventReceiverConfig::paper()).expect("paper settings");
    for p in warm_up {
        rx.push_packet(p);
    }
    let last = warm_up.last().expect("a warm-up stream");
    let (mut seq, mut end_ns) = (last.seq, last.end_ns);
    let events: usize = cycle.iter().map(EventPacket::len).sum();
    eprintln!(
        "{name}: {} packets, {:.0} events per packet on average (min {}, max {}), tracking {:?}",
        cycle.len(),
        events as f64 / cycle.len() as f64,
        cycle.iter().map(EventPacket::len).min().unwrap_or(0),
        cycle.iter().map(EventPacket::len).max().unwrap_or(0),
        rx.status()
            .estimate_px
            .map(|p| [p[0].round(), p[1].round()])
    );
    let mut k = 0;
    c.bench_function(name, |b| {
        b.iter_custom(|iters| {
            let start = Instant::now();
            for _ in 0..iters {
                let len = cycle.len();
                let p = &mut cycle[k % len];
                k += 1;
                seq += 1;
                p.seq = seq;
                p.start_ns = end_ns;
                end_ns += PACKET_NS;
                p.end_ns = end_ns;
                black_box(rx.push_packet(black_box(p)));
            }
            start.elapsed()
        })
    });
    assert_eq!(rx.segmenter_errors(), 0);
    assert!(rx.rejections().is_empty(), "{:?}", rx.rejections());
}

fn receiver(c: &mut Criterion) {
    // One full sweep period of the blob scene is 2 s = 50 packets; warm up on the first second.
    let scene = MovingBlobScene::new(W, H);
    let blob = convert((0..=300).map(|k| scene.frame(k * RENDER_NS)));
    let (warm_up, rest) = blob.split_at(25);
    bench_cycle(c, "event_receiver/typical", warm_up, rest[..50].to_vec());

    // The same view while the observer moves: the background slides 2 px per render.
    let still = scene.frame(0);
    let shifted = |k: usize| {
        let mut f = vec![0u8; still.len()];
        for y in 0..usize::from(H) {
            for x in 0..usize::from(W) {
                let sx = (x + 2 * k).min(usize::from(W) - 1);
                let (d, s) = (3 * (y * usize::from(W) + x), 3 * (y * usize::from(W) + sx));
                f[d..d + 3].copy_from_slice(&still[s..s + 3]);
            }
        }
        f
    };
    let sliding = convert((0..=40).map(shifted));
    bench_cycle(c, "event_receiver/peak_broad", warm_up, sliding);

    // Peak, all local: 32 000 events inside the tracking window around the target.
    let mut probe = EventReceiver::new(EventReceiverConfig::paper()).expect("paper settings");
    for p in warm_up {
        probe.push_packet(p);
    }
    let w = probe.tracking_window();
    let (ww, wh) = (u32::from(w.x1 - w.x0), u32::from(w.y1 - w.y0));
    let n = 32_000u32;
    let mut dense = EventPacket {
        xs: Vec::new(),
        ys: Vec::new(),
        dt_ns: Vec::new(),
        ..blob[25].clone()
    };
    for i in 0..n {
        let h = i.wrapping_mul(2_654_435_761);
        dense.xs.push(w.x0 + (h % ww) as u16);
        dense.ys.push(w.y0 + ((h >> 12) % wh) as u16);
        dense.dt_ns.push(i * 1_000);
    }
    dense.on_bits = EventPacket::pack_polarities((0..n).map(|i| {
        if i % 2 == 0 {
            Polarity::On
        } else {
            Polarity::Off
        }
    }));
    bench_cycle(c, "event_receiver/peak_local", warm_up, vec![dense]);

    // An empty packet while tracking (most packets of a mission).
    let quiet = EventPacket {
        xs: Vec::new(),
        ys: Vec::new(),
        dt_ns: Vec::new(),
        on_bits: Vec::new(),
        ..blob[25].clone()
    };
    bench_cycle(c, "event_receiver/quiet", warm_up, vec![quiet]);
}

criterion_group!(benches, receiver);
criterion_main!(benches);
