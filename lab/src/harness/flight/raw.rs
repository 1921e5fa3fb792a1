//! Event cameras' output as files: each packet's events collected and written as Prophesee EVT
//! 3.0 (`waggle link --events-raw`), for Metavision tools and `waggle decode --events`.

use std::path::Path;

use anyhow::{Context, Result};
use event_camera::Event;
use event_formats::evt3;
use proto::EventPacket;
use proto::scene::{IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX};

/// Appends `packet`'s events to `out` (absolute times).
pub fn packet_events(packet: &EventPacket, out: &mut Vec<Event>) {
    out.extend((0..packet.len()).map(|i| Event {
        t_ns: packet.t_ns(i),
        x: packet.xs[i],
        y: packet.ys[i],
        polarity: packet.polarity(i),
    }));
}

/// Writes `events` of the paper's sensor to `path` as EVT 3.0.
pub fn write_raw(path: &Path, events: &[Event]) -> Result<()> {
    let mut bytes = Vec::new();
    evt3::write(&mut bytes, IMAGE_WIDTH_PX, IMAGE_HEIGHT_PX, events)
        .with_context(|| format!("encoding {}", path.display()))?;
    std::fs::write(path, bytes).with_context(|| format!("writing {}", path.display()))
}
