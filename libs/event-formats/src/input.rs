//! The writers' common precondition: every event on the sensor, in time order.

use event_camera::Event;

/// Why a list of events cannot be written, in any format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum EventsError {
    #[error("event at ({x}, {y}) is outside the {width}×{height} sensor")]
    Outside {
        x: u16,
        y: u16,
        width: u16,
        height: u16,
    },
    #[error("events must be in time order: {t_ns} ns after {previous_ns} ns")]
    NotSorted { t_ns: u64, previous_ns: u64 },
}

/// Checks `events` of a `width`×`height` sensor, the first no earlier than `previous_ns`;
/// returns the last event's time (or `previous_ns` when there is none).
pub(crate) fn check_events(
    events: &[Event],
    width: u16,
    height: u16,
    mut previous_ns: u64,
) -> Result<u64, EventsError> {
    for e in events {
        if e.x >= width || e.y >= height {
            return Err(EventsError::Outside {
                x: e.x,
                y: e.y,
                width,
                height,
            });
        }
        if e.t_ns < previous_ns {
            return Err(EventsError::NotSorted {
                t_ns: e.t_ns,
                previous_ns,
            });
        }
        previous_ns = e.t_ns;
    }
    Ok(previous_ns)
}
