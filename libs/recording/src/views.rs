//! Viewing channels derived from the raw messages: event-frame images at a viewing rate and
//! one-line log messages for tokens, frames, decisions, faults and session controls.

use event_camera::picture::{NO_EVENT_COLOUR, OFF_COLOUR, ON_COLOUR};
use image::{Rgb, RgbImage};
use proto::{EventPacket, InputState, Polarity, SessionEvent, TICK_NS};

use crate::foxglove::LogLevel;
use crate::topics::Decoded;

/// An event-frame picture closing at `stamp_ns`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EventImage {
    pub stamp_ns: u64,
    pub image: RgbImage,
}

/// Accumulates one observer's packets into event-frame pictures (ON blue, OFF red, the last
/// event at a pixel deciding its colour, white elsewhere) over `period_ns` of sim time.
#[derive(Debug, Clone)]
pub struct EventView {
    period_ns: u64,
    window_end_ns: Option<u64>,
    image: RgbImage,
}

impl EventView {
    /// A view emitting one picture per `period_ns` (rounded up to whole 40 ms packets).
    pub fn new(period_ns: u64) -> Self {
        Self {
            period_ns: period_ns.max(1).div_ceil(TICK_NS) * TICK_NS,
            window_end_ns: None,
            image: RgbImage::new(0, 0),
        }
    }

    /// Adds a packet; returns the picture of the window it completes, if any. Events outside
    /// the frame are skipped (a decoded packet never has any).
    pub fn push(&mut self, p: &EventPacket) -> Option<EventImage> {
        let (w, h) = (u32::from(p.width), u32::from(p.height));
        if (w, h) != self.image.dimensions() || self.window_end_ns.is_none() {
            self.image = blank(w, h);
            // Windows are aligned to multiples of the period.
            self.window_end_ns = Some(p.end_ns.div_ceil(self.period_ns).max(1) * self.period_ns);
        }
        for i in 0..p.xs.len().min(p.ys.len()) {
            let (x, y) = (u32::from(p.xs[i]), u32::from(p.ys[i]));
            if x >= w || y >= h || i / 8 >= p.on_bits.len() {
                continue;
            }
            let colour = match p.polarity(i) {
                Polarity::On => ON_COLOUR,
                Polarity::Off => OFF_COLOUR,
            };
            self.image.put_pixel(x, y, Rgb(colour));
        }
        let end = self.window_end_ns?;
        if p.end_ns < end {
            return None;
        }
        let image = EventImage {
            stamp_ns: p.end_ns,
            image: std::mem::replace(&mut self.image, blank(w, h)),
        };
        self.window_end_ns = Some((p.end_ns / self.period_ns + 1) * self.period_ns);
        Some(image)
    }
}

/// A `w`×`h` picture with no events.
fn blank(w: u32, h: u32) -> RgbImage {
    RgbImage::from_pixel(w, h, Rgb(NO_EVENT_COLOUR))
}

/// A log line for a message worth reading in a log panel: (level, source name, text).
pub fn log_line(msg: &Decoded) -> Option<(LogLevel, String, String)> {
    let info = |name: &str, text: String| Some((LogLevel::Info, name.to_string(), text));
    match msg {
        Decoded::TokenEvent(t) => info(
            t.observer.as_str(),
            format!(
                "token #{} {:?} at {:.3} s",
                t.seq,
                t.token,
                s(t.confirmed_ns)
            ),
        ),
        Decoded::FrameEvent(f) => info(
            f.observer.as_str(),
            format!(
                "frame #{} round {}: payload {:06b}, final NULL at {:.3} s",
                f.seq,
                f.round,
                f.frame.payload,
                s(f.frame.final_null_ns())
            ),
        ),
        Decoded::Decision(d) => info(
            d.observer.as_str(),
            format!(
                "decision round {} at {:.3} s: {} (sources {})",
                d.round,
                s(d.decided_ns),
                d.assignment
                    .map_or("stay home".to_string(), |a| format!("go to {a}")),
                d.sources
                    .iter()
                    .map(|f| format!(
                        "{}#{}@{:.3}s",
                        f.offer.site,
                        f.frame_seq,
                        s(f.final_null_ns)
                    ))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        ),
        Decoded::Fault(f) => Some((
            LogLevel::Warning,
            f.observer.to_string(),
            format!(
                "fault {:?} from {:.3} s until {:?}",
                f.kind,
                s(f.from_ns),
                f.until_ns.map(s)
            ),
        )),
        Decoded::RejectReport(r) if r.total() > 0 => Some((
            LogLevel::Warning,
            r.process.clone(),
            format!(
                "dropped {} message(s): {}",
                r.total(),
                r.counts
                    .iter()
                    .map(|c| format!("{} {} ×{}", c.key, c.reason, c.count))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        )),
        Decoded::ObserverStatus(st) if st.input == InputState::Missing => Some((
            LogLevel::Warning,
            st.observer.to_string(),
            format!("packet of tick {} missing", st.tick),
        )),
        Decoded::SessionTick(t) if !t.controls.is_empty() => info(
            "scheduler",
            t.controls
                .iter()
                .map(|c| match c.event {
                    SessionEvent::RoundReset { round } => format!("round {round} reset"),
                    SessionEvent::WindowOpen { round } => format!("round {round} window open"),
                    SessionEvent::WindowClose { round } => format!("round {round} window close"),
                    SessionEvent::MissionEnd => "mission end".to_string(),
                })
                .collect::<Vec<_>>()
                .join("; "),
        ),
        Decoded::BroadcastTick(b) => b.broadcast.as_ref().map(|b| {
            (
                LogLevel::Info,
                "scheduler".to_string(),
                format!(
                    "broadcast round {} from {:.3} s: {} (acquisition {})",
                    b.round,
                    s(b.start_ns),
                    b.offers
                        .iter()
                        .map(|o| o.to_bits())
                        .collect::<Vec<_>>()
                        .join(" "),
                    b.acquisition
                ),
            )
        }),
        Decoded::MissionReport(r) => info(
            "scheduler",
            format!(
                "mission report at {:.3} s: {} work units, end reason {}",
                s(r.end_ns),
                r.work_units,
                r.end_reason
            ),
        ),
        _ => None,
    }
}

fn s(ns: u64) -> f64 {
    ns as f64 / 1e9
}

#[cfg(test)]
mod tests {
    use super::*;

    fn packet(tick: u64, events: &[(u16, u16, Polarity)]) -> EventPacket {
        let events: Vec<_> = events.iter().map(|&(x, y, p)| (x, y, 0, p)).collect();
        EventPacket::from_events(
            tick - 1,
            ((tick - 1) * TICK_NS, tick * TICK_NS),
            (4, 2),
            &events,
        )
    }

    fn px(img: &EventImage, x: u32, y: u32) -> [u8; 3] {
        img.image.get_pixel(x, y).0
    }

    #[test]
    fn event_view_paints_on_blue_off_red_and_emits_once_per_period() {
        let mut v = EventView::new(3 * TICK_NS);
        assert_eq!(v.push(&packet(1, &[(0, 0, Polarity::On)])), None);
        assert_eq!(v.push(&packet(2, &[(1, 1, Polarity::Off)])), None);
        // The last event at a pixel decides its colour.
        let img = v
            .push(&packet(3, &[(0, 0, Polarity::Off), (3, 1, Polarity::On)]))
            .expect("third packet completes the 120 ms window");
        assert_eq!(img.stamp_ns, 3 * TICK_NS);
        assert_eq!(
            (img.image.dimensions(), img.image.as_raw().len()),
            ((4, 2), 24)
        );
        assert_eq!(px(&img, 0, 0), OFF_COLOUR);
        assert_eq!(px(&img, 1, 1), OFF_COLOUR);
        assert_eq!(px(&img, 3, 1), ON_COLOUR);
        assert_eq!(px(&img, 2, 0), NO_EVENT_COLOUR);
        // The next window starts blank; empty packets still advance it.
        assert_eq!(v.push(&packet(4, &[])), None);
        assert_eq!(v.push(&packet(5, &[])), None);
        let img = v.push(&packet(6, &[])).unwrap();
        assert_eq!(img.stamp_ns, 6 * TICK_NS);
        assert!(img.image.pixels().all(|c| c.0 == NO_EVENT_COLOUR));
        // A gap in the stream (dropout) closes the window at the next packet.
        let img = v.push(&packet(20, &[(2, 0, Polarity::On)])).unwrap();
        assert_eq!(px(&img, 2, 0), ON_COLOUR);
        // Windows stay aligned to multiples of the period: 800 ms closed one, 840 ms the next.
        assert_eq!(v.push(&packet(21, &[])).unwrap().stamp_ns, 21 * TICK_NS);
        assert_eq!(v.push(&packet(22, &[])), None);
    }

    #[test]
    fn logs_name_their_source() {
        let f = proto::Fault {
            observer: proto::ObserverId::new("O2").unwrap(),
            kind: proto::FaultKind::BlackInput,
            from_ns: 0,
            until_ns: None,
        };
        let (level, name, text) = log_line(&Decoded::Fault(f)).unwrap();
        assert_eq!((level, name.as_str()), (LogLevel::Warning, "O2"));
        assert!(text.contains("BlackInput"), "{text}");
        assert!(log_line(&Decoded::Clock(proto::ClockTick::at(1).unwrap())).is_none());
    }
}
