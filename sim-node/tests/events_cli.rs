//! `sim-node events` on the real scene: packet cadence and the black-input fault.

use std::process::Command;

#[test]
fn five_seconds_give_125_contiguous_packets_per_observer_and_black_input_only_empty_ones() {
    let dir = std::env::temp_dir().join(format!("waggle-events-cli-{}", std::process::id()));
    let out = Command::new(env!("CARGO_BIN_EXE_sim-node"))
        .args([
            "events",
            "--observers",
            "3",
            "--seconds",
            "5",
            "--black",
            "O2",
            "--out",
        ])
        .arg(&dir)
        .output()
        .expect("run sim-node");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("summary.json")).expect("summary"))
            .expect("json");
    for o in ["O1", "O2", "O3"] {
        let s = &summary["observers"][o];
        assert_eq!(s["packets"], 125, "{o}: {s}");
        assert_eq!(s["first_seq"], 0, "{o}: {s}");
        assert_eq!(s["last_seq"], 124, "{o}: {s}");
        assert_eq!(s["contiguous"], true, "{o}: {s}");
        assert_eq!(s["last_end_ns"], 5_000_000_000u64, "{o}: {s}");
    }
    assert_eq!(
        summary["observers"]["O2"]["events"], 0,
        "black input produced events"
    );
    for o in ["O1", "O3"] {
        let s = &summary["observers"][o];
        assert!(
            s["events"].as_u64().unwrap() > 10_000,
            "{o}: the moving performer produced too few events: {s}"
        );
        assert!(
            s["on"].as_u64().unwrap() > 0 && s["off"].as_u64().unwrap() > 0,
            "{o}: {s}"
        );
        let png =
            std::fs::metadata(dir.join(format!("{o}_busiest_packet.png"))).expect("event picture");
        assert!(png.len() > 100);
    }
    std::fs::remove_dir_all(&dir).ok();
}
