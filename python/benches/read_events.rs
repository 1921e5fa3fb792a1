//! `waggle.read_events`'s Rust half on a recording, without Python: how fast the reader alone
//! streams the file, and how fast it turns one observer's packets into records.
//!
//! `cargo bench -p waggle-python --bench read_events -- PATH [OBSERVER] [REPEATS]` (a
//! `session.mcap`; default O1, 7 repeats). `python/benches/read_events.py` measures the Python
//! call against the official `mcap` reader; this one tells how much of its time is the file's
//! decompression, which every reader pays.

use std::path::PathBuf;
use std::time::Instant;

use proto::ObserverId;
use recording::ReadError;
use waggle_native::recorded::read_events_from;

fn best_and_median(mut seconds: Vec<f64>) -> (f64, f64) {
    seconds.sort_by(f64::total_cmp);
    (seconds[0], seconds[seconds.len() / 2])
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // `cargo bench` adds `--bench`; anything else is ours.
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let Some(path) = args.first().map(PathBuf::from) else {
        eprintln!(
            "usage: cargo bench -p waggle-python --bench read_events -- PATH [OBSERVER] [REPEATS]"
        );
        return Ok(());
    };
    let observer = ObserverId::new(args.get(1).map_or("O1", String::as_str))?;
    let repeats = args.get(2).map_or(Ok(7), |r| r.parse::<usize>())?.max(1);
    let topic = format!("/sensor/{observer}/events");
    // One loop after the other: alternating them, each would start on the memory the other
    // just gave back.
    let (mut stream_s, mut records_s) = (Vec::new(), Vec::new());
    let mut events = 0;
    for _ in 0..repeats {
        let t = Instant::now();
        events = read_events_from(&path, Some(&observer), false)?.events();
        records_s.push(t.elapsed().as_secs_f64());
    }
    let mut bytes = 0u64;
    for _ in 0..repeats {
        let t = Instant::now();
        bytes = 0;
        recording::read_recording::<ReadError>(&path, |m| {
            if m.topic == topic {
                bytes += m.data.len() as u64;
            }
            Ok(())
        })?;
        stream_s.push(t.elapsed().as_secs_f64());
    }
    let (best, med) = best_and_median(stream_s);
    println!("read_recording alone ({topic}: {bytes} bytes): best {best:.4} s, median {med:.4} s");
    let (best, med) = best_and_median(records_s);
    println!(
        "read_events_from ({events} events): best {best:.4} s, median {med:.4} s, {:.1} M events/s (best)",
        events as f64 / best / 1e6
    );
    Ok(())
}
