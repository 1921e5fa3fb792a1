//! Seeds of the run files the launcher and the lab read back: per-trial records and render
//! cache entries from the lab's encoders, compose files from the compose file's printer.

use std::collections::BTreeMap;

use super::{SeedError, SeedFile, io};

/// Record files of two link trials, written by the lab's own record encoder: one observer
/// that released the broadcast, and two on a flight of their own with a plug-in's failure.
pub(super) fn trial_record_seeds(out: &mut Vec<SeedFile>) -> Result<(), SeedError> {
    use run_format::trial_record::{
        ObserverTrial, PluginFailure, Provenance, TokenTiming, Tracking, TrialFlight, TrialRecord,
        encode,
    };
    let observer = |events: Option<u64>| ObserverTrial {
        released: vec!["011010".into()],
        success: true,
        release_s: vec![12.48],
        tokens: 14,
        token_timing: TokenTiming {
            matched: 14,
            missed: 0,
            extra: 1,
            mean_abs_error_ms: Some(13.5),
            max_abs_error_ms: Some(40.0),
            missed_at: Vec::new(),
            extra_at: vec![run_format::link_out::TokenOut {
                token: "BIT1".into(),
                t_s: 9.52,
            }],
        },
        latency_s: vec![0.52],
        vs_ideal_s: vec![Some(0.04), None],
        messages: 312,
        messages_lost: 3,
        events_received: events,
        events_removed: events.map(|n| n / 10),
        events_removed_ego: None,
    };
    let provenance = Provenance {
        version: "0.1.0 sha256:0123456789abcdef".into(),
        cpu: "seed CPU".into(),
        renderer: "waggle-raster/1".into(),
    };
    let one = TrialRecord {
        index: 0,
        seed: 0x1234_5678_9abc_def0,
        success: true,
        observers: [("O1".to_owned(), observer(None))].into(),
        flight: None,
        plugin_failure: None,
    };
    let two = TrialRecord {
        index: 7,
        seed: 7,
        success: false,
        observers: [
            ("O1".to_owned(), observer(Some(41_000))),
            ("O2".to_owned(), observer(None)),
        ]
        .into(),
        flight: Some(TrialFlight {
            performer_tracking: Tracking {
                rms_m: 0.021,
                max_m: 0.08,
            },
            contact_steps: 0,
        }),
        plugin_failure: Some(PluginFailure {
            outcome: "failed".into(),
            reason: "ValueError: bad frame".into(),
        }),
    };
    for (name, point, record) in [("rgb", "rgb-0.5", one), ("events", "events-wind-0.25", two)] {
        let bytes = encode(point, provenance.clone(), &record)
            .map_err(|e| io("trial_record", name, std::io::Error::other(e)))?;
        out.push(("trial_record", name.into(), bytes));
    }
    Ok(())
}

/// `waggle compose only-a`'s nodes, with their arguments as it writes them: every node on
/// `local` with a recorder, or (`two_hosts`) the cameras on `b` and the observers on `c`, with
/// the faults `--black O2 --kill O3@20 --throttle O1@0:250:0` on the cameras' lines.
fn only_a_nodes(modality: &str, two_hosts: bool) -> Vec<compose_file::Node> {
    let words = |s: &str| s.split_whitespace().map(str::to_owned).collect::<Vec<_>>();
    let (cameras, observers) = if two_hosts {
        ("b", "c")
    } else {
        ("local", "local")
    };
    let mut lines = vec![
        ("sim".to_owned(), "local", "sim-node", "run".to_owned()),
        (
            "scheduler".to_owned(),
            "local",
            "scheduler-node",
            format!("--modality {modality} --offers A --rounds 2 --flights sequential"),
        ),
        (
            "performer".to_owned(),
            "local",
            "performer-node",
            String::new(),
        ),
    ];
    let faults = ["--throttle 0:250:0", "--black", "--dropout-ns 20000000000"];
    for (k, fault) in faults.iter().enumerate() {
        let o = format!("O{}", k + 1);
        let fault = if two_hosts { fault } else { "" };
        lines.push((
            format!("camera-{o}"),
            cameras,
            "sim-node",
            format!("camera --observer {o} --modality {modality} --render raster {fault}"),
        ));
        lines.push((
            format!("observer-{o}"),
            observers,
            "observer-node",
            format!("--id {o} --modality {modality} --grace-ms 60000"),
        ));
    }
    lines.push((
        "recorder".to_owned(),
        "local",
        "recorder-node",
        format!(
            "--case-name only-a --modality {modality} --event-view-hz 2 --rgb-every 25 \
             --chunk-kib 4096 --flush-ms 1000 --linger-ms 1000"
        ),
    ));
    lines
        .into_iter()
        .map(|(role, host, binary, args)| compose_file::Node {
            role: role.parse().expect("a process name"),
            host: host.into(),
            binary: binary.into(),
            args: words(&args),
        })
        .collect()
}

/// Compose files as `waggle compose only-a` writes them, printed by the compose file's own
/// printer: one host on loopback without authentication, and two hosts with a site's router,
/// QUIC and injected faults.
pub(super) fn compose_seeds(out: &mut Vec<SeedFile>) -> Result<(), SeedError> {
    use compose_file::{COMPOSE_VERSION, Compose, Router, SiteRouter};
    let case = run_format::case::case_source("only-a").map_err(|e| {
        io(
            "compose_toml",
            "only-a",
            std::io::Error::other(e.to_string()),
        )
    })?;
    let one_host = Compose {
        version: COMPOSE_VERSION,
        session: "seed-one-host".into(),
        modality: proto::Modality::Events,
        case_name: "only-a".into(),
        auth: false,
        plain_tcp: false,
        secrets: None,
        case: case.clone(),
        router: Router {
            host: "local".into(),
            listen: vec!["tcp/127.0.0.1:0".into()],
            connect: Vec::new(),
        },
        sites: Vec::new(),
        faults: compose_file::fault::ExtraFaults::default(),
        nodes: only_a_nodes("events", false),
    };
    let two_hosts = Compose {
        session: "seed-two-hosts".into(),
        modality: proto::Modality::Rgb,
        auth: true,
        secrets: Some("two.secrets".into()),
        router: Router {
            host: "local".into(),
            listen: vec!["quic/10.0.0.1:7447".into()],
            connect: Vec::new(),
        },
        sites: vec![SiteRouter {
            host: "c".into(),
            listen: vec!["quic/10.0.0.3:7447".into()],
            serves: Vec::new(),
        }],
        faults: compose_file::fault::ExtraFaults {
            black: vec!["O2".parse().expect("a fault")],
            kill: vec!["O3@20".parse().expect("a fault")],
            throttle: vec!["O1@0:250:0".parse().expect("a fault")],
        },
        nodes: only_a_nodes("rgb", true),
        ..one_host.clone()
    };
    for (name, compose) in [("one-host", one_host), ("two-hosts", two_hosts)] {
        let text = compose
            .to_toml()
            .map_err(|e| io("compose_toml", name, std::io::Error::other(e.to_string())))?;
        out.push(("compose_toml", name.into(), text.into_bytes()));
    }
    Ok(())
}

/// A render cache entry written by the cache's own encoder: two observers' 8×6 cameras, each a
/// whole first frame, then an unchanged render and a changed rectangle; the ideal receivers'
/// output as the lab writes it (per modality, per observer: payloads, frames, tokens).
pub(super) fn render_cache_seed(out: &mut Vec<SeedFile>) -> Result<(), SeedError> {
    use proto::{FrameChange, PixelRect};
    use run_format::link_out::{FrameOut, ObserverOut, TokenOut};
    use run_format::render_cache::{CacheEntry, FORMAT, Meta, TrackMeta};
    let (width, height) = (8usize, 6usize);
    let frame_len = 3 * width * height;
    let rect = PixelRect {
        x: 2,
        y: 1,
        width: 3,
        height: 2,
    };
    let mut tracks = Vec::new();
    let mut pixels = Vec::new();
    for o in 0..2u8 {
        let frame: Vec<u8> = (0..frame_len)
            .map(|i| (i as u8).wrapping_mul(7) ^ o)
            .collect();
        let renders = [
            (FrameChange::All, frame),
            (FrameChange::Nothing, Vec::new()),
            (FrameChange::Within(rect), vec![200 + o; 3 * 3 * 2]),
        ];
        tracks.push(TrackMeta {
            frame_len,
            width,
            updates: renders
                .iter()
                .enumerate()
                .map(|(k, (c, p))| (10_000_000 * k as u64, *c, p.len()))
                .collect(),
        });
        pixels.push(renders.into_iter().map(|(_, p)| p).collect());
    }
    let observer = ObserverOut {
        payloads: vec!["011010".into()],
        frames: vec![FrameOut {
            payload: "011010".into(),
            final_null_s: 12.44,
        }],
        tokens: vec![
            TokenOut {
                token: "s1".into(),
                t_s: 0.52,
            },
            TokenOut {
                token: "n".into(),
                t_s: 0.96,
            },
        ],
    };
    let entry = CacheEntry {
        meta: Meta {
            format: FORMAT.into(),
            key: "5eed".repeat(16),
            spec: "FlightSpec { seed }".into(),
            provenance: run_format::trial_record::Provenance {
                version: "0.1.0 sha256:0123456789abcdef".into(),
                cpu: "seed CPU".into(),
                renderer: "waggle-raster/1".into(),
            },
            ideal: BTreeMap::from([(proto::Modality::Rgb, vec![observer.clone(), observer])]),
            sim_ns: 30_000_000,
            performer_max_tracking_error_m: 0.0125,
            contact_steps: 0,
            tracks,
        },
        pixels,
    };
    let bytes = entry
        .encode()
        .map_err(|e| io("render_cache", "two-observers", std::io::Error::other(e)))?;
    out.push(("render_cache", "two-observers".into(), bytes));
    Ok(())
}
