//! Event-camera file formats, so that real cameras' recordings and Waggle's synthetic events
//! meet, each written and read: [`evt3`], Prophesee's EVT 3.0 (`.raw`), and [`aedat4`],
//! iniVation's AEDAT 4.0 (`.aedat4`).
//!
//! Pure code over byte slices and `Write`rs: no file system, no clock.

pub mod aedat4;
pub mod evt3;
mod flatbuf;
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
