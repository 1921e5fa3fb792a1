//! Event recordings read into one time-ordered event list: EVT 3.0 or 2.0 `.raw`, DAT, AEDAT4 or the
//! `event_camera_msgs/EventPacket` topic of a ROS 2 bag, told apart by their first bytes (or a
//! bag directory) unless the format is named.

use commands::decode::EventFormat;
use std::io::Read;
use std::path::Path;

use anyhow::{Context, Result, bail};
use event_camera::Event;
use event_formats::{aedat4, dat, evt2, evt3};

/// A recording's events and what it says of its sensor.
#[derive(Debug)]
pub struct EventRead {
    /// The format read, for the report.
    pub format: String,
    /// The sensor's size, when the file states it.
    pub size: Option<(u16, u16)>,
    pub events: Vec<Event>,
}

impl EventRead {
    /// The sensor's size: the file's, else the smallest sensor holding every event.
    pub fn sensor_size(&self) -> (u16, u16) {
        self.size.unwrap_or_else(|| {
            self.events.iter().fold((1, 1), |(w, h), e| {
                (w.max(e.x.saturating_add(1)), h.max(e.y.saturating_add(1)))
            })
        })
    }
}

/// A format, once told.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Known {
    Raw,
    Dat,
    Aedat4,
    Bag,
}

const AEDAT4_MAGIC: &[u8] = b"#!AER-DAT4.0";
const MCAP_MAGIC: &[u8] = b"\x89MCAP";

/// The format of `path` when not named.
fn detect(path: &Path) -> Result<Known> {
    if path.is_dir() {
        return Ok(Known::Bag);
    }
    let mut head = [0u8; 16];
    let mut file =
        std::fs::File::open(path).with_context(|| format!("opening {}", path.display()))?;
    let n = file
        .read(&mut head)
        .with_context(|| format!("reading {}", path.display()))?;
    let head = &head[..n];
    Ok(if head.starts_with(AEDAT4_MAGIC) {
        Known::Aedat4
    } else if head.starts_with(MCAP_MAGIC) {
        Known::Bag
    } else if path.extension().is_some_and(|e| e == "dat") {
        Known::Dat
    } else if head.starts_with(b"%") || path.extension().is_some_and(|e| e == "raw") {
        if dat_header(path)? {
            Known::Dat
        } else {
            Known::Raw
        }
    } else {
        bail!(
            "{}: not an event recording this tool knows (EVT 3.0 or 2.0 `.raw`, DAT, AEDAT4, a \
             ROS 2 MCAP bag); name the format with --format",
            path.display()
        )
    })
}

/// True when the `%` header of `path` is a DAT file's: a `Version` line and no `evt`/`format`.
fn dat_header(path: &Path) -> Result<bool> {
    let mut head = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(64 * 1024).read_to_end(&mut head))
        .with_context(|| format!("reading {}", path.display()))?;
    let mut version = false;
    for line in head.split(|&b| b == b'\n') {
        let Some(line) = line.strip_prefix(b"% ") else {
            break;
        };
        if line.starts_with(b"evt ") || line.starts_with(b"format ") {
            return Ok(false);
        }
        version |= line.starts_with(b"Version ");
    }
    Ok(version)
}

/// Reads the events of `path` (of `topic`, for a bag).
pub fn read_events(path: &Path, format: EventFormat, topic: Option<&str>) -> Result<EventRead> {
    let format = match format {
        EventFormat::Auto => detect(path)?,
        EventFormat::Raw => Known::Raw,
        EventFormat::Dat => Known::Dat,
        EventFormat::Aedat4 => Known::Aedat4,
        EventFormat::Bag => Known::Bag,
    };
    if topic.is_some() && format != Known::Bag {
        bail!(
            "--topic names a bag's topic; {} is not a bag",
            path.display()
        );
    }
    let read = || std::fs::read(path).with_context(|| format!("reading {}", path.display()));
    let decoding = || format!("decoding {}", path.display());
    Ok(match format {
        Known::Raw => {
            let bytes = read()?;
            let (format, rec) = if evt2::is_evt2(&bytes) {
                ("evt2", evt2::read(&bytes).with_context(decoding)?)
            } else {
                ("evt3", evt3::read(&bytes).with_context(decoding)?)
            };
            EventRead {
                format: format.into(),
                size: rec.geometry.map(|g| (g.width, g.height)),
                events: rec.events,
            }
        }
        Known::Dat => {
            let rec = dat::read(&read()?).with_context(decoding)?;
            EventRead {
                format: "dat".into(),
                size: rec.geometry.map(|g| (g.width, g.height)),
                events: rec.events,
            }
        }
        Known::Aedat4 => {
            let rec = aedat4::read(&read()?).with_context(decoding)?;
            EventRead {
                format: format!("aedat4 ({})", rec.compression.name()),
                size: rec.geometry.map(|g| (g.width, g.height)),
                events: rec.events,
            }
        }
        Known::Bag => {
            // A bag of `waggle export ros2` holds every observer's camera; O1 when not chosen.
            let bag = ros2_bag::ingest::read_event_bag(path, topic, Some("/O1/events"))
                .with_context(decoding)?;
            EventRead {
                format: format!("bag {} ({} messages)", bag.topic, bag.messages),
                size: Some((bag.width, bag.height)),
                events: bag.events,
            }
        }
    })
}
