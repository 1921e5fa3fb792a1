//! `waggle sensor-fit`: a real camera's recording measured for the terms of Waggle's sensor model.

use crate::decode::EventFormat;
use clap::Args;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct SensorFitArgs {
    /// The recording: EVT 3.0 or 2.0 `.raw`, DAT, AEDAT4 or a ROS 2 bag (as `waggle decode
    /// --events` reads them).
    pub file: PathBuf,
    /// The recording's format (by default told from the file).
    #[arg(long, value_enum, default_value_t = EventFormat::default())]
    pub format: EventFormat,
    /// A bag's topic (default: the only one of its kind).
    #[arg(long)]
    pub topic: Option<String>,
    /// A stretch where nothing in view moved, START_S:END_S from the first event: every event
    /// in it is background. Without it, the background is the events with no event at a
    /// neighbouring pixel within 10 ms, corrected for the noise events that have one by chance.
    #[arg(long = "static", value_name = "START_S:END_S", value_parser = parse_window)]
    pub static_window: Option<(f64, f64)>,
    /// Write the fitted terms as a preset file, usable as `--sensor-preset FILE` (and as a
    /// study file's `sensor_preset`).
    #[arg(long, value_name = "PRESET")]
    pub out: Option<PathBuf>,
    /// Print the measurement as one JSON object (keys sorted) instead of the report.
    #[arg(long)]
    pub json: bool,
}

/// `START_S:END_S`, seconds, `0 ≤ START < END`.
pub fn parse_window(s: &str) -> Result<(f64, f64), String> {
    let (a, b) = s
        .split_once(':')
        .ok_or_else(|| format!("{s:?} is not START_S:END_S (e.g. 0:2.5)"))?;
    let num = |v: &str| {
        v.trim()
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite() && *x >= 0.0)
            .ok_or_else(|| format!("{v:?} is not a non-negative number of seconds"))
    };
    let (start, end) = (num(a)?, num(b)?);
    if end <= start {
        return Err(format!("the window {s:?} ends before it starts"));
    }
    Ok((start, end))
}

#[cfg(test)]
mod tests {
    use super::parse_window;

    #[test]
    fn windows_parse_and_bad_ones_are_named() {
        assert_eq!(parse_window("0:2.5"), Ok((0.0, 2.5)));
        assert!(parse_window("2").unwrap_err().contains("START_S:END_S"));
        assert!(parse_window("3:1").unwrap_err().contains("ends before"));
        assert!(parse_window("-1:1").unwrap_err().contains("non-negative"));
    }
}
