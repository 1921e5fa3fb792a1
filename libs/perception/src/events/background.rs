//! An online estimate of the sensor's background-activity rate, Hz per pixel, from the events
//! themselves: a receiver does not know its sensor's noise level, but it can measure it.
//!
//! Background activity (shot noise, leak, hot pixels) is spread over the whole sensor; a target's
//! events sit in a few places. So the estimate counts events per coarse cell over the last second
//! of packets and takes the **median cell's** rate: a target, even one that fills several cells,
//! moves the median of a 20×15 grid not at all, and with no noise the estimate is exactly zero.
//! (Counting only *isolated* events would underestimate: at 5 Hz per pixel most noise events
//! have a neighbour within a ±15 ms window.) Only activity over more than half the sensor — the
//! observer's own motion, a lighting change — raises it, and then the filter only asks more of
//! events the tracker discards as broad activity anyway.

use std::collections::VecDeque;

/// Side of a cell, pixels.
pub const CELL_PX: u16 = 32;

/// The estimate over a sliding window of packets.
#[derive(Debug, Clone)]
pub struct BackgroundEstimate {
    cols: usize,
    /// Pixels of each cell (edge cells are smaller).
    area: Vec<u32>,
    /// Events per cell over the window, and per packet (oldest first) to subtract.
    sums: Vec<u32>,
    per_packet: VecDeque<(u64, Vec<u16>)>,
    /// Sensor time the window spans, ns.
    span_ns: u64,
    packets: usize,
    scratch: Vec<u32>,
}

impl BackgroundEstimate {
    /// An estimate for a `width`×`height` sensor over the last `packets` packets.
    pub fn new(width: u16, height: u16, packets: usize) -> Self {
        let cell = u32::from(CELL_PX);
        let (w, h) = (u32::from(width), u32::from(height));
        let (cols, rows) = (w.div_ceil(cell) as usize, h.div_ceil(cell) as usize);
        let area = (0..rows * cols)
            .map(|c| {
                let (cx, cy) = ((c % cols) as u32, (c / cols) as u32);
                (w - cx * cell).min(cell) * (h - cy * cell).min(cell)
            })
            .collect();
        Self {
            cols,
            area,
            sums: vec![0; rows * cols],
            per_packet: VecDeque::with_capacity(packets + 1),
            span_ns: 0,
            packets: packets.max(1),
            scratch: Vec::new(),
        }
    }

    /// Adds one packet of `period_ns` with its events at `pixels`.
    pub fn add(&mut self, period_ns: u64, pixels: impl Iterator<Item = (u16, u16)>) {
        let mut counts = if self.per_packet.len() >= self.packets {
            let (old_ns, mut old) = self.per_packet.pop_front().unwrap_or_default();
            for (s, &o) in self.sums.iter_mut().zip(&old) {
                *s -= u32::from(o);
            }
            self.span_ns -= old_ns;
            old.fill(0);
            old
        } else {
            vec![0u16; self.sums.len()]
        };
        for (x, y) in pixels {
            let c = usize::from(y / CELL_PX) * self.cols + usize::from(x / CELL_PX);
            if let Some(n) = counts.get_mut(c) {
                *n = n.saturating_add(1);
            }
        }
        for (s, &n) in self.sums.iter_mut().zip(&counts) {
            *s += u32::from(n);
        }
        self.span_ns += period_ns;
        self.per_packet.push_back((period_ns, counts));
    }

    /// The median cell's event rate, Hz per pixel (0 before any packet).
    pub fn rate_hz(&mut self) -> f64 {
        if self.span_ns == 0 || self.sums.is_empty() {
            return 0.0;
        }
        // Compare rates as counts scaled to a common area without dividing: count·(max area) /
        // area, in integers, so the median is exact and independent of float rounding.
        let max_area = self.area.iter().copied().max().unwrap_or(1);
        self.scratch.clear();
        self.scratch.extend(
            self.sums
                .iter()
                .zip(&self.area)
                .map(|(&s, &a)| (u64::from(s) * u64::from(max_area) / u64::from(a.max(1))) as u32),
        );
        let mid = (self.scratch.len() - 1) / 2;
        let (_, &mut median, _) = self.scratch.select_nth_unstable(mid);
        f64::from(median) / f64::from(max_area) / (self.span_ns as f64 * 1e-9)
    }

    /// Packets in the window so far (at most the window's length).
    pub fn packets(&self) -> usize {
        self.per_packet.len()
    }

    /// Forgets everything (a restarted stream).
    pub fn clear(&mut self) {
        self.sums.fill(0);
        self.per_packet.clear();
        self.span_ns = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_isolated_events_is_exactly_zero_and_a_local_cluster_does_not_move_it() {
        let mut b = BackgroundEstimate::new(640, 480, 25);
        assert_eq!(b.rate_hz(), 0.0);
        for _ in 0..30 {
            // 400 events a packet, all inside a 60×60 px corner: a target, not noise.
            b.add(40_000_000, (0..400u16).map(|i| (i % 60, (i / 60) % 60)));
        }
        assert_eq!(b.rate_hz(), 0.0);
    }

    #[test]
    fn uniform_activity_is_measured_and_old_packets_leave_the_window() {
        let mut b = BackgroundEstimate::new(640, 480, 25);
        // One event per pixel of every 8×8 block per packet: 1/64 events per pixel per 40 ms.
        let grid = || (0..80u16).flat_map(|x| (0..60u16).map(move |y| (x * 8, y * 8)));
        for _ in 0..25 {
            b.add(40_000_000, grid());
        }
        let want = 1.0 / 64.0 / 0.04;
        assert!((b.rate_hz() - want).abs() < 1e-9 * want, "{}", b.rate_hz());
        for _ in 0..25 {
            b.add(40_000_000, std::iter::empty());
        }
        assert_eq!(b.rate_hz(), 0.0);
        b.add(40_000_000, grid());
        b.clear();
        assert_eq!(b.rate_hz(), 0.0);
    }
}
