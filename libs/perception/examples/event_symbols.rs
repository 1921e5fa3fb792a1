//! Replays an EVT 3.0 recording (e.g. from `waggle link --events-raw`) through the paper's event
//! receiver and prints, per confirmed token, why the segmenter read it as it did, and per
//! symbol the trajectory it classified: the tool for asking why a symbol came out `?`.
//!
//! `cargo run --release -p perception --example event_symbols -- FILE.raw [--observer I/N]
//!  [--trajectories OUT.csv] [--packets OUT.csv] [--events FROM_NS:TO_NS:OUT.csv]`
//!
//! `--observer I/N` places the camera as observer I (0-based) of the built-in formation of N
//! (default 0/1), which sets the receiver's rectification as `waggle link` does. The token list
//! is JSON lines on stdout; `--trajectories` writes `symbol,token,stamp_ns,x_px,y_px,supported`
//! per sample; `--packets` writes, per packet, its end, its events, the estimate, the ON and
//! OFF events in the tracker's window, any interruption, tracker fault or rejection, the NULL
//! gate, and the majority share of a confirming window that put the track in doubt;
//! `--events` writes the recording's events with `FROM_NS < t_ns <= TO_NS` as `t_ns,x,y,on`.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use event_camera::packets::Packetizer;
use perception::events::tracker::TrackFault;
use perception::events::{EventReceiver, EventReceiverConfig};
use proto::scene::Formation;
use proto::{EventPacket, Rectification};

struct Options {
    file: PathBuf,
    observer: (usize, usize),
    trajectories: Option<PathBuf>,
    packets: Option<PathBuf>,
    events: Option<(u64, u64, PathBuf)>,
}

fn parse_args() -> Result<Options> {
    let mut args = std::env::args().skip(1);
    let file = PathBuf::from(args.next().context(
        "usage: FILE.raw [--observer I/N] [--trajectories OUT.csv] [--packets OUT.csv] [--events FROM:TO:OUT]",
    )?);
    let mut options = Options {
        file,
        observer: (0, 1),
        trajectories: None,
        packets: None,
        events: None,
    };
    while let Some(a) = args.next() {
        let value = args.next().with_context(|| format!("{a} needs a value"))?;
        match a.as_str() {
            "--observer" => {
                let (i, n) = value.split_once('/').context("--observer I/N")?;
                options.observer = (i.parse()?, n.parse()?);
            }
            "--trajectories" => options.trajectories = Some(value.into()),
            "--packets" => options.packets = Some(value.into()),
            "--events" => {
                let mut parts = value.splitn(3, ':');
                let mut next = || parts.next().context("--events FROM_NS:TO_NS:OUT.csv");
                let (from, to) = (next()?.parse()?, next()?.parse()?);
                options.events = Some((from, to, next()?.into()));
            }
            other => bail!("unknown option {other}"),
        }
    }
    Ok(options)
}

fn main() -> Result<()> {
    let options = parse_args()?;
    let bytes = std::fs::read(&options.file)
        .with_context(|| format!("reading {}", options.file.display()))?;
    let recording = event_formats::evt3::read(&bytes)
        .with_context(|| format!("decoding {}", options.file.display()))?;
    let (i, n) = options.observer;
    let formation = Formation::standard(n).map_err(|e| anyhow::anyhow!("--observer: {e:?}"))?;
    let placement = formation
        .placement(i)
        .context("--observer: no such observer")?;
    let mut config = EventReceiverConfig::paper();
    config.segmenter = config
        .segmenter
        .rectified(placement.camera(), Rectification::Pitched);
    let mut receiver = EventReceiver::new(config)?;
    let mut packet_rows = String::from(
        "end_ns,events,x_px,y_px,window_on,window_off,interruption,fault,rejected,null_allowed,doubt_share\n",
    );
    let mut take = |p: EventPacket, receiver: &mut EventReceiver| {
        let out = receiver.push_packet(&p);
        let (x, y) = out
            .point_px
            .map_or((String::new(), String::new()), |[x, y]| {
                (format!("{x:.3}"), format!("{y:.3}"))
            });
        packet_rows.push_str(&format!(
            "{},{},{x},{y},{},{},{},\"{}\",{},{},{}\n",
            p.end_ns,
            p.len(),
            out.window_on_off
                .map_or(String::new(), |c| c[0].to_string()),
            out.window_on_off
                .map_or(String::new(), |c| c[1].to_string()),
            out.interruption.map_or(String::new(), |c| format!("{c:?}")),
            out.track_fault.map_or(String::new(), |f| format!("{f:?}")),
            out.rejected.map_or(String::new(), |r| format!("{r:?}")),
            out.null_allowed,
            match out.track_doubt {
                Some(TrackFault::OneSidedPolarity {
                    majority_fraction, ..
                }) => format!("{majority_fraction:.4}"),
                _ => String::new(),
            }
        ));
    };
    let mut packetizer = Packetizer::new();
    let last_ns = recording.events.last().map_or(0, |e| e.t_ns);
    for e in &recording.events {
        packetizer.push(e, |p| take(p, &mut receiver));
    }
    // Two seconds of silence so a final rest is confirmed, as `waggle decode` does.
    packetizer.finish(last_ns + 2_000_000_000, |p| take(p, &mut receiver));
    let stdout = std::io::stdout();
    let mut stdout = stdout.lock();
    for t in receiver.tokens() {
        writeln!(
            stdout,
            "{{\"token\":\"{:?}\",\"stamp_ns\":{},\"late\":{},\"cause\":{:?}}}",
            t.token,
            t.stamp_ns,
            t.late,
            format!("{:?}", t.cause)
        )?;
    }
    if let Some(path) = options.trajectories {
        let mut rows = String::from("symbol,token,stamp_ns,x_px,y_px,supported\n");
        for (k, s) in receiver.trajectories().iter().enumerate() {
            for step in &s.samples {
                rows.push_str(&format!(
                    "{k},{:?},{},{:.3},{:.3},{}\n",
                    s.token, step.stamp_ns, step.point_px[0], step.point_px[1], step.supported
                ));
            }
        }
        std::fs::write(&path, rows).with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some(path) = options.packets {
        std::fs::write(&path, packet_rows)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some((from_ns, to_ns, path)) = options.events {
        let mut rows = String::from("t_ns,x,y,on\n");
        for e in &recording.events {
            if from_ns < e.t_ns && e.t_ns <= to_ns {
                let on = u8::from(e.polarity == proto::Polarity::On);
                rows.push_str(&format!("{},{},{},{on}\n", e.t_ns, e.x, e.y));
            }
        }
        std::fs::write(&path, rows).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}
