//! `recorder-node --out FILE.mcap --session S …`: records every key of a session
//! (`waggle/<session>/**`) into one MCAP file.
//!
//! It takes part in the start-up handshake (role `recorder`), so with `--recorder` given to
//! every node the clock starts only once it is subscribed and it records from tick 0. It closes
//! a chunk and flushes the file every `--flush-ms` of wall time, so a kill loses at most that
//! much; it finishes the file (summary and footer) after `MissionEnd`, on SIGINT/SIGTERM, or
//! when the simulator and the scheduler are both gone. With `--live ADDR:PORT` it also serves
//! every view channel over a Foxglove WebSocket while it records ([`live`]); with
//! `--ros2-domain N` it publishes the session as ROS 2 topics on `rmw_zenoh`
//! ([`ros2_bag::live`]).

mod live;

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use bus::{Bus, Inbound, NodeArgs, Process, Rejects};
use clap::Parser;
use node_args::{RecorderArgs, RecorderOutput};
use proto::{RejectReason, Role};
use recording::foxglove::LogLevel;
use recording::{Recorded, RecorderOptions, SessionInfo, SessionWriter};
use ros2_bag::live::{LiveOptions, LiveView};

#[derive(Parser)]
#[command(
    name = "recorder-node",
    version,
    about = "Records a Waggle session into one MCAP file"
)]
struct Args {
    #[command(flatten)]
    own: RecorderArgs,
    #[command(flatten)]
    output: RecorderOutput,
    #[command(flatten)]
    node: NodeArgs,
}

fn main() -> Result<()> {
    node_args::init_logging();
    let args = Args::parse();
    let stop = bus::on_stop_signal();
    let node = &args.node;
    let mut writer = session_writer(&args)?;
    if let Some(addr) = args.output.live {
        let live = live::Live::start(addr, &node.session, &writer.expected_views())?;
        writer = writer.with_tap(Box::new(live));
    }

    let mut ros2 = ros2_view(&args)?;

    let mut bus = Bus::open_node(node).context("opening the Zenoh session")?;
    let keys = bus.keys().clone();
    bus.subscribe(&keys.all())?;
    node.join(&mut bus, &Process::singleton(Role::Recorder))
        .context("start-up handshake")?;
    let sim_alive = keys.alive(Role::Sim, Role::Sim.as_str())?;
    let scheduler_alive = keys.alive(Role::Scheduler, Role::Scheduler.as_str())?;

    let flush_every = Duration::from_millis(args.own.flush_ms.max(1));
    let linger = Duration::from_millis(args.own.linger_ms);
    let mut last_flush = Instant::now();
    let mut mission_end_at: Option<Instant> = None;
    let mut peers_gone_at: Option<Instant> = None;
    let mut last_data = Instant::now();
    let mut warnings = 0u64;
    let why = loop {
        if stop.load(Ordering::SeqCst) {
            break "signal";
        }
        match bus.recv(Duration::from_millis(50)) {
            Some(Inbound::Data { key, payload }) => {
                last_data = Instant::now();
                if let Some(view) = ros2.as_mut() {
                    publish_ros2(view, keys.prefix(), &key, &payload, writer.sim_time_ns());
                }
                match writer.record(&key, &payload)? {
                    Recorded::Message { mission_end, .. } => {
                        if mission_end {
                            mission_end_at.get_or_insert_with(Instant::now);
                        }
                    }
                    Recorded::UnknownKey => {
                        warnings += 1;
                        if warnings <= 20 {
                            tracing::warn!(key, "message on a key of no known type (recorded raw)");
                        }
                    }
                    Recorded::Undecodable { kind, error } => {
                        warnings += 1;
                        if warnings <= 20 {
                            tracing::warn!(key, ?kind, %error, "undecodable payload (recorded raw)");
                        }
                    }
                }
            }
            Some(Inbound::Liveliness { .. }) | None => {
                if !bus.is_alive(&sim_alive) && !bus.is_alive(&scheduler_alive) {
                    peers_gone_at.get_or_insert_with(Instant::now);
                }
            }
        }
        // After the mission end (or once the simulator and the scheduler are gone: liveliness
        // may overtake their last messages), keep draining until the bus is quiet.
        let ending = mission_end_at.or(peers_gone_at);
        if let Some(t) = ending
            && (last_data.elapsed() >= linger
                || t.elapsed() >= 10 * linger.max(Duration::from_millis(500)))
        {
            break if mission_end_at.is_some() {
                "mission end"
            } else {
                "simulator and scheduler gone"
            };
        }
        if last_flush.elapsed() >= flush_every {
            writer.flush()?;
            last_flush = Instant::now();
        }
    };
    writer.note(LogLevel::Info, &format!("recorder stopped: {why}"))?;
    let stats = writer.stats().clone();
    let mut extra = BTreeMap::new();
    extra.insert("stopped".to_string(), why.to_string());
    extra.insert("cpu_s".to_string(), cpu_seconds());
    writer.finish(extra).context("finishing the MCAP file")?;
    let messages: u64 = stats.messages.values().sum();
    tracing::info!(
        why,
        messages,
        unknown = stats.unknown_keys.values().sum::<u64>(),
        undecodable = stats.undecodable.values().sum::<u64>(),
        file = %args.output.out.display(),
        "recording finished"
    );
    // What could not be decoded was recorded raw all the same; reported like every process's
    // drops so the summary counts it.
    let mut rejects = Rejects::new(Role::Recorder.as_str(), &keys);
    for (topic, n) in &stats.undecodable {
        rejects.add(topic, RejectReason::Undecodable, *n);
    }
    for (key, n) in &stats.unknown_keys {
        rejects.add(key, RejectReason::UnexpectedKey, *n);
    }
    let _ = bus.put(
        &keys.rejects(Role::Recorder, Role::Recorder.as_str())?,
        &rejects.report(),
    );
    let _ = bus.close();
    if let Some(view) = ros2 {
        let counts = view.close().context("closing the live ROS 2 view")?;
        tracing::info!(
            published = counts.published.values().sum::<u64>(),
            topics = counts.published.len(),
            failed = counts.failed,
            "live ROS 2 view closed"
        );
    }
    Ok(())
}

/// The live ROS 2 view, when `--ros2-domain` asks for one.
fn ros2_view(args: &Args) -> Result<Option<LiveView>> {
    let Some(domain) = args.output.ros2_domain else {
        return Ok(None);
    };
    let options = LiveOptions {
        domain,
        router: args
            .output
            .ros2_router
            .clone()
            .unwrap_or_else(|| ros2_bag::live::DEFAULT_ROUTER.to_string()),
        observers: args.node.observers,
        session: args.node.session.clone(),
    };
    LiveView::start(&options)
        .map(Some)
        .context("starting the live ROS 2 view")
}

/// Hands a session message to the live ROS 2 view (a key of no known kind, or a payload that
/// does not decode, is the recording's to count).
fn publish_ros2(view: &mut LiveView, prefix: &str, key: &str, payload: &[u8], last_ns: u64) {
    let Some(topic) = recording::classify(prefix, key) else {
        return;
    };
    if let Ok(msg) = recording::decode(topic.kind, payload) {
        let log_time_ns = msg.sim_time_ns().unwrap_or(last_ns);
        view.publish(&topic.topic, msg, log_time_ns);
    }
}

/// The MCAP writer for `args.output.out` (directory created), its header and metadata written.
fn session_writer(args: &Args) -> Result<SessionWriter<BufWriter<File>>> {
    let case_toml = match &args.output.case_file {
        Some(p) => {
            Some(std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?)
        }
        None => None,
    };
    let info = SessionInfo {
        session: args.node.session.clone(),
        observers: args.node.observers,
        case_name: args.own.case_name.clone(),
        case_toml,
        modality: args.own.modality.map(|m| m.as_str().to_string()),
        sensor_args: args.own.sensor.to_args(),
        events_from_input: args.own.events_from_input,
    };
    let options = RecorderOptions {
        chunk_bytes: args.own.chunk_kib.saturating_mul(1024),
        event_view_period_ns: (args.own.event_view_hz > 0.0)
            .then(|| (1e9 / args.own.event_view_hz).round() as u64),
        rgb_every: if args.own.all_rgb {
            1
        } else {
            args.own.rgb_every.max(1)
        },
        zstd_level: 0,
        events_from_input: args.own.events_from_input,
    };
    if let Some(dir) = args
        .output
        .out
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
    {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let file = File::create(&args.output.out)
        .with_context(|| format!("creating {}", args.output.out.display()))?;
    let mut writer = SessionWriter::new(BufWriter::with_capacity(1 << 20, file), &info, options)
        .context("starting the MCAP file")?;
    writer.flush()?;
    Ok(writer)
}

/// CPU time (user + system) of this process so far, seconds, as text; empty if unknown.
fn cpu_seconds() -> String {
    std::fs::read_to_string("/proc/self/stat")
        .ok()
        .and_then(|s| {
            let rest = s[s.rfind(')')? + 2..].to_string();
            let f: Vec<&str> = rest.split_whitespace().collect();
            Some((f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?) / 100.0)
        })
        .map(|cpu| format!("{cpu:.2}"))
        .unwrap_or_default()
}
