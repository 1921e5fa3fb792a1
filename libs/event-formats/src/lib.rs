//! Event-camera file formats, so that real cameras' recordings and Waggle's synthetic events
//! meet, each written and read: Prophesee's [`evt3`] and [`evt2`] (EVT 3.0 and 2.0, `.raw`) and
//! [`dat`] (`.dat`), and iniVation's [`aedat4`] (AEDAT 4.0, `.aedat4`).
//!
//! Pure code over byte slices and `Write`rs: no file system, no clock.

pub mod aedat4;
pub mod dat;
pub mod evt2;
pub mod evt3;
mod flatbuf;
mod header;
pub mod input;

pub use input::EventsError;

/// An event for the format tests.
#[cfg(test)]
pub(crate) fn test_event(t_ns: u64, x: u16, y: u16, on: bool) -> event_camera::Event {
    event_camera::Event {
        t_ns,
        x,
        y,
        polarity: if on {
            event_camera::Polarity::On
        } else {
            event_camera::Polarity::Off
        },
    }
}

/// `events` as a microsecond format gives them back: each time floored to a whole µs.
#[cfg(test)]
pub(crate) fn floored_to_us(events: &[event_camera::Event]) -> Vec<event_camera::Event> {
    events
        .iter()
        .map(|e| event_camera::Event {
            t_ns: e.t_ns / 1000 * 1000,
            ..*e
        })
        .collect()
}
