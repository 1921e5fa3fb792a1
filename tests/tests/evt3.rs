//! Waggle's EVT 3.0 writer against an independent decoder: the PyPI `evt3` package (installed by
//! `deploy/setup.sh` into `tests/js/.venv`) reads a `.raw` file of Waggle's synthetic events —
//! a moving blob through v2e's default noisy sensor, with a silence longer than two wraps of the
//! format's 24-bit clock — and finds the same events at microsecond resolution.

use event_camera::synthetic::MovingBlobScene;
use event_camera::{CameraConfig, Event, EventCamera, Polarity};
use event_formats::evt3;
use perturb::Perturbation;
use std::process::Command;
use waggle_tests::workspace_root;

const W: u16 = 320;
const H: u16 = 240;

fn synthetic_events() -> Vec<Event> {
    let model = Perturbation::with_preset::<&str>(Some("v2e-default"), &[])
        .unwrap()
        .event_sensor(7);
    let mut camera = EventCamera::new(CameraConfig::paper(W, H).with_model(model)).unwrap();
    let scene = MovingBlobScene::new(W, H);
    let mut events = Vec::new();
    // One second of renders, a 40 s silence (two clock wraps), then another second.
    for k in 0..=200u64 {
        let t = if k <= 100 { k } else { k + 4000 } * 10_000_000;
        for packet in camera
            .push_frame(t, &scene.frame(t % 1_000_000_000))
            .unwrap()
        {
            events.extend((0..packet.len()).map(|i| Event {
                t_ns: packet.t_ns(i),
                x: packet.xs[i],
                y: packet.ys[i],
                polarity: packet.polarity(i),
            }));
        }
    }
    events
}

#[test]
fn an_independent_decoder_reads_what_waggle_writes() {
    let events = synthetic_events();
    assert!(events.len() > 1000, "{} events", events.len());
    let path = std::env::temp_dir().join(format!("waggle-evt3-{}.raw", std::process::id()));
    let mut raw = Vec::new();
    evt3::write(&mut raw, W, H, &events).unwrap();
    std::fs::write(&path, &raw).unwrap();

    let mut check = 0u64;
    for (i, e) in events.iter().enumerate() {
        let v = (e.t_ns / 1000)
            .wrapping_mul(1_000_003)
            .wrapping_add(u64::from(e.x) * 1009)
            .wrapping_add(u64::from(e.y) * 17)
            .wrapping_add(u64::from(e.polarity == Polarity::On));
        check = check.wrapping_add(v.wrapping_mul(i as u64 + 1));
    }
    let js = workspace_root().join("tests/js");
    let python = js.join(".venv/bin/python");
    assert!(
        python.is_file(),
        "run bash deploy/setup.sh (tests/js/.venv)"
    );
    let out = Command::new(python)
        .arg(js.join("read_evt3.py"))
        .arg(&path)
        .output()
        .expect("run read_evt3.py");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let _ = std::fs::remove_file(&path);
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["width"], u64::from(W));
    assert_eq!(report["height"], u64::from(H));
    assert_eq!(report["events"], events.len() as u64);
    assert_eq!(
        report["last_t_us"],
        events.last().map(|e| e.t_ns / 1000).unwrap()
    );
    assert_eq!(report["checksum"], check, "{report}");
}
