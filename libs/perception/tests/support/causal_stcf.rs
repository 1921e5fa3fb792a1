//! The causal STCF as Guo & Delbruck publish it ("Low Cost and Latency Event Camera Background
//! Activity Denoising", IEEE TPAMI 45(1), 2023): one time per pixel; an event is kept when at
//! least `k` distinct pixels of its 8 neighbours fired within the window *before* it. Not the
//! receiver's filter: the comparison it is measured against, for accuracy (the ROC in
//! `tests/denoise.rs`) and for cost (the floor in `benches/noise_front_end.rs`), both on this one
//! definition.

use proto::EventPacket;

/// (events seen, events kept) of `packets`, in stream order, on a `width` × `height` sensor
/// (events off it are skipped). Times are wrapping microseconds, as the receiver keeps them.
pub fn causal_stcf(
    packets: &[EventPacket],
    (width, height): (u16, u16),
    window_us: u32,
    k: u32,
) -> (u64, u64) {
    let (w, h) = (usize::from(width), usize::from(height));
    let stride = w + 2;
    // Out of reach of every time of a stream shorter than 2³⁰ µs (≈ 18 min).
    let never = 0u32.wrapping_sub(1 << 30);
    let mut map = vec![never; stride * (h + 2)];
    let (mut seen, mut kept) = (0, 0);
    for p in packets {
        for i in 0..p.len() {
            let (x, y) = (usize::from(p.xs[i]), usize::from(p.ys[i]));
            if x >= w || y >= h {
                continue;
            }
            let t = ((p.start_ns + u64::from(p.dt_ns[i])) / 1_000) as u32;
            let c = (y + 1) * stride + x + 1;
            let support: u32 = [
                c - stride - 1,
                c - stride,
                c - stride + 1,
                c - 1,
                c + 1,
                c + stride - 1,
                c + stride,
                c + stride + 1,
            ]
            .iter()
            .map(|&n| u32::from(t.wrapping_sub(map[n]) <= window_us))
            .sum();
            seen += 1;
            kept += u64::from(support >= k);
            map[c] = t;
        }
    }
    (seen, kept)
}
