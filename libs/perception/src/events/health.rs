//! Packet health: is this packet well-formed, and does it directly continue the last one?
//!
//! The receiver's NULL condition needs *continuous valid packets*: an empty packet is healthy
//! silence, a missing one is not. This module tells the two apart from the packet metadata alone
//! (sequence number, watermarks, `valid`, `continuous`, sensor size) and counts what it rejects.

use std::collections::BTreeMap;

use proto::EventPacket;
use proto::codec::Validate;

/// Why a packet was not used at all. Counted per reason.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum PacketRejection {
    /// Bytes that do not decode as an event packet (format version, body, trailing bytes).
    Undecodable,
    /// Arrays of different lengths, events outside the sensor or the interval, reversed
    /// watermarks.
    Inconsistent,
    /// Sensor size differs from the receiver's.
    Dimensions,
    /// Interval is not one packet period long, or does not sit where its sequence number says.
    Watermarks,
    /// Sequence number not after the last accepted one, with time not moving on either
    /// (a duplicate or a reordered packet).
    OutOfOrder,
}

impl PacketRejection {
    pub fn label(self) -> &'static str {
        match self {
            PacketRejection::Undecodable => "undecodable",
            PacketRejection::Inconsistent => "inconsistent",
            PacketRejection::Dimensions => "dimensions",
            PacketRejection::Watermarks => "watermarks",
            PacketRejection::OutOfOrder => "out-of-order",
        }
    }
}

impl std::fmt::Display for PacketRejection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.label())
    }
}

/// A well-formed packet that does not directly continue the previous one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Discontinuity {
    /// Packets are missing between the last accepted one and this one.
    SequenceGap { missing: u64 },
    /// The sequence restarted (a new camera process) while time moved on.
    Restart,
    /// The sensor marked the interval as not trustworthy.
    Invalid,
    /// The sensor marked the interval as not following its previous one.
    NotContinuous,
}

/// The verdict on one packet.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Delivery {
    /// Valid, continuous, directly after the previous packet.
    Continuous,
    /// Well-formed but breaking continuity. `events_usable` is false for invalid or
    /// non-continuous intervals, whose events must not be read as a continuation.
    Discontinuous {
        cause: Discontinuity,
        events_usable: bool,
    },
    /// Not used.
    Rejected {
        reason: PacketRejection,
        detail: String,
    },
}

/// Per-sensor delivery checks.
#[derive(Debug, Clone)]
pub struct DeliveryMonitor {
    width: u16,
    height: u16,
    period_ns: u64,
    /// (seq, end watermark) of the last accepted packet.
    last: Option<(u64, u64)>,
    rejections: BTreeMap<PacketRejection, u64>,
}

impl DeliveryMonitor {
    pub fn new(width: u16, height: u16, period_ns: u64) -> Self {
        Self {
            width,
            height,
            period_ns,
            last: None,
            rejections: BTreeMap::new(),
        }
    }

    /// Rejections so far, per reason.
    pub fn rejections(&self) -> &BTreeMap<PacketRejection, u64> {
        &self.rejections
    }

    /// End watermark of the last accepted packet.
    pub fn last_end_ns(&self) -> Option<u64> {
        self.last.map(|(_, end)| end)
    }

    /// Forgets the last packet (a round reset): the next one starts a new stream. Counters stay.
    pub fn forget(&mut self) {
        self.last = None;
    }

    /// Counts a rejection decided elsewhere (bytes that did not decode).
    pub fn count(&mut self, reason: PacketRejection) {
        *self.rejections.entry(reason).or_insert(0) += 1;
    }

    /// Judges `packet` and, unless it is rejected, makes it the last accepted packet.
    pub fn check(&mut self, packet: &EventPacket) -> Delivery {
        match self.judge(packet) {
            Ok(delivery) => {
                self.last = Some((packet.seq, packet.end_ns));
                delivery
            }
            Err((reason, detail)) => {
                self.count(reason);
                Delivery::Rejected { reason, detail }
            }
        }
    }

    fn judge(&self, p: &EventPacket) -> Result<Delivery, (PacketRejection, String)> {
        p.validate()
            .map_err(|e| (PacketRejection::Inconsistent, e))?;
        if (p.width, p.height) != (self.width, self.height) {
            return Err((
                PacketRejection::Dimensions,
                format!(
                    "packet {} is {}x{}, sensor is {}x{}",
                    p.seq, p.width, p.height, self.width, self.height
                ),
            ));
        }
        if p.end_ns - p.start_ns != self.period_ns {
            return Err((
                PacketRejection::Watermarks,
                format!(
                    "packet {} covers ({}, {}] ns, not one {} ns period",
                    p.seq, p.start_ns, p.end_ns, self.period_ns
                ),
            ));
        }
        let mut cause = None;
        if let Some((last_seq, last_end_ns)) = self.last {
            if p.seq <= last_seq {
                if p.start_ns < last_end_ns {
                    return Err((
                        PacketRejection::OutOfOrder,
                        format!("packet {} after packet {last_seq}", p.seq),
                    ));
                }
                cause = Some(Discontinuity::Restart);
            } else {
                let missing = p.seq - last_seq - 1;
                let expected_start = missing
                    .checked_mul(self.period_ns)
                    .and_then(|d| d.checked_add(last_end_ns));
                if expected_start != Some(p.start_ns) {
                    return Err((
                        PacketRejection::Watermarks,
                        format!(
                            "packet {} starts at {} ns; after packet {last_seq} ending at {last_end_ns} ns it should start at {expected_start:?} ns",
                            p.seq, p.start_ns
                        ),
                    ));
                }
                if missing > 0 {
                    cause = Some(Discontinuity::SequenceGap { missing });
                }
            }
        }
        if !p.valid {
            cause = Some(Discontinuity::Invalid);
        } else if !p.continuous {
            cause = Some(Discontinuity::NotContinuous);
        }
        Ok(match cause {
            None => Delivery::Continuous,
            Some(cause) => Delivery::Discontinuous {
                cause,
                events_usable: p.valid && p.continuous,
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const P: u64 = 40_000_000;

    fn packet(seq: u64) -> EventPacket {
        let events = [
            (1, 3, 5, proto::Polarity::On),
            (2, 4, 6, proto::Polarity::Off),
        ];
        EventPacket::from_events(seq, (seq * P, (seq + 1) * P), (640, 480), &events)
    }

    #[test]
    fn contiguous_packets_are_continuous_and_gaps_count_missing_packets() {
        let mut m = DeliveryMonitor::new(640, 480, P);
        assert_eq!(
            m.check(&packet(7)),
            Delivery::Continuous,
            "any first sequence number"
        );
        assert_eq!(m.check(&packet(8)), Delivery::Continuous);
        assert_eq!(
            m.check(&packet(11)),
            Delivery::Discontinuous {
                cause: Discontinuity::SequenceGap { missing: 2 },
                events_usable: true
            }
        );
        assert_eq!(m.check(&packet(12)), Delivery::Continuous);
        assert!(m.rejections().is_empty());
    }

    #[test]
    fn invalid_and_discontinuous_flags_break_continuity_and_their_events_are_unusable() {
        let mut m = DeliveryMonitor::new(640, 480, P);
        m.check(&packet(0));
        let mut p = packet(1);
        p.valid = false;
        assert_eq!(
            m.check(&p),
            Delivery::Discontinuous {
                cause: Discontinuity::Invalid,
                events_usable: false
            }
        );
        let mut p = packet(2);
        p.continuous = false;
        assert_eq!(
            m.check(&p),
            Delivery::Discontinuous {
                cause: Discontinuity::NotContinuous,
                events_usable: false
            }
        );
        assert_eq!(m.check(&packet(3)), Delivery::Continuous);
    }

    #[test]
    fn malformed_packets_are_rejected_and_counted_by_reason() {
        let mut m = DeliveryMonitor::new(640, 480, P);
        m.check(&packet(0));
        let mut p = packet(1);
        p.ys.pop();
        assert!(matches!(
            m.check(&p),
            Delivery::Rejected {
                reason: PacketRejection::Inconsistent,
                ..
            }
        ));
        let mut p = packet(1);
        p.xs[0] = 640;
        assert!(matches!(
            m.check(&p),
            Delivery::Rejected {
                reason: PacketRejection::Inconsistent,
                ..
            }
        ));
        let mut p = packet(1);
        p.width = 320;
        p.xs = vec![1, 2];
        assert!(matches!(
            m.check(&p),
            Delivery::Rejected {
                reason: PacketRejection::Dimensions,
                ..
            }
        ));
        let mut p = packet(1);
        p.start_ns += 1;
        assert!(matches!(
            m.check(&p),
            Delivery::Rejected {
                reason: PacketRejection::Watermarks,
                ..
            }
        ));
        let mut p = packet(2);
        p.start_ns -= P;
        p.end_ns -= P;
        assert!(matches!(
            m.check(&p),
            Delivery::Rejected {
                reason: PacketRejection::Watermarks,
                ..
            }
        ));
        assert!(matches!(
            m.check(&packet(0)),
            Delivery::Rejected {
                reason: PacketRejection::OutOfOrder,
                ..
            }
        ));
        let counts: Vec<_> = m.rejections().iter().map(|(r, n)| (*r, *n)).collect();
        assert_eq!(
            counts,
            vec![
                (PacketRejection::Inconsistent, 2),
                (PacketRejection::Dimensions, 1),
                (PacketRejection::Watermarks, 2),
                (PacketRejection::OutOfOrder, 1),
            ]
        );
        // Rejected packets did not move the baseline: packet 1 still continues packet 0.
        assert_eq!(m.check(&packet(1)), Delivery::Continuous);
    }

    #[test]
    fn a_restarted_sequence_with_later_time_is_a_discontinuity_not_a_rejection() {
        let mut m = DeliveryMonitor::new(640, 480, P);
        m.check(&packet(50));
        let mut p = packet(0);
        p.start_ns = 60 * P;
        p.end_ns = 61 * P;
        assert_eq!(
            m.check(&p),
            Delivery::Discontinuous {
                cause: Discontinuity::Restart,
                events_usable: true
            }
        );
    }
}
