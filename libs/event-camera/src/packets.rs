//! Events in time order cut into the receiver's 40 ms packets, as they come: packet k covers
//! `(k·P, (k+1)·P]` of the recording's clock (an event at exactly t = 0 joins packet 0), empty
//! packets included, and is handed out once an event or the stream's clock is past its end,
//! or the stream is finished. `waggle decode` (a whole file) and `waggle observe` (a live topic) both cut with
//! this one type, so the same events give the same packets either way.

use proto::EventPacket;
use proto::scene::{IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX};

use crate::{Event, Polarity};

/// The receiver's packet period, ns (the paper's 25 Hz).
pub const PACKET_NS: u64 = proto::TICK_NS;

/// The cutter: the packet being filled and what it holds.
#[derive(Debug, Default)]
pub struct Packetizer {
    /// Index of the packet being filled.
    next: u64,
    /// Its events: x, y, time after the packet's start (ns), polarity.
    inside: Vec<(u16, u16, u32, Polarity)>,
    /// Events older than the packet being filled, dropped.
    late: u64,
}

impl Packetizer {
    pub fn new() -> Self {
        Self::default()
    }

    /// Packets handed out so far.
    pub fn packets(&self) -> u64 {
        self.next
    }

    /// Events that came after a later packet had been handed out, and were dropped.
    pub fn late(&self) -> u64 {
        self.late
    }

    fn emit(&mut self) -> EventPacket {
        let (start, end) = (self.next * PACKET_NS, (self.next + 1) * PACKET_NS);
        let packet = EventPacket::from_events(
            self.next,
            (start, end),
            (IMAGE_WIDTH_PX, IMAGE_HEIGHT_PX),
            &self.inside,
        );
        self.inside.clear();
        self.next += 1;
        packet
    }

    /// Adds `e`, handing every packet that ends before it to `out`.
    pub fn push(&mut self, e: &Event, mut out: impl FnMut(EventPacket)) {
        let start = self.next * PACKET_NS;
        if self.next > 0 && e.t_ns <= start {
            self.late += 1;
            return;
        }
        while e.t_ns > (self.next + 1) * PACKET_NS {
            out(self.emit());
        }
        let dt = e.t_ns.saturating_sub(self.next * PACKET_NS) as u32;
        self.inside.push((e.x, e.y, dt, e.polarity));
    }

    /// Hands out every packet that ends before `now_ns`: the stream has reached that time, so
    /// no later event can fall into them (a camera's clock words say so even when no event
    /// comes, and a packet of silence is told from a missing one).
    pub fn advance_to(&mut self, now_ns: u64, mut out: impl FnMut(EventPacket)) {
        while (self.next + 1) * PACKET_NS < now_ns {
            out(self.emit());
        }
    }

    /// Hands out every packet up to the one holding `end_ns` (at least one packet in all).
    pub fn finish(&mut self, end_ns: u64, mut out: impl FnMut(EventPacket)) {
        let packets = end_ns.div_ceil(PACKET_NS).max(1);
        while self.next < packets {
            out(self.emit());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn event(t_ns: u64) -> Event {
        Event {
            t_ns,
            x: 1,
            y: 2,
            polarity: Polarity::On,
        }
    }

    #[test]
    fn packets_cover_half_open_intervals_and_late_events_are_counted() {
        let mut p = Packetizer::new();
        let got = std::cell::RefCell::new(Vec::new());
        let take = |k: EventPacket| got.borrow_mut().push((k.seq, k.len()));
        for t in [0, PACKET_NS, PACKET_NS + 1, 3 * PACKET_NS] {
            p.push(&event(t), take);
        }
        // An event of packet 1 after packet 2 has begun filling: late.
        p.push(&event(2 * PACKET_NS), take);
        // The clock at the end of packet 3: packet 3 may still receive an event.
        p.advance_to(4 * PACKET_NS, take);
        assert_eq!(got.borrow().len(), 3);
        p.advance_to(4 * PACKET_NS + 1, take);
        assert_eq!(got.borrow().len(), 4);
        p.finish(4 * PACKET_NS + 1, take);
        assert_eq!(*got.borrow(), [(0, 2), (1, 1), (2, 1), (3, 0), (4, 0)]);
        assert_eq!(p.late(), 1);
        assert_eq!(p.packets(), 5);
        let mut empty = Packetizer::new();
        let mut n = 0;
        empty.finish(0, |_| n += 1);
        assert_eq!(n, 1, "at least one packet");
    }
}
