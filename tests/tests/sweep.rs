//! `waggle sweep` and `waggle report`: the report is generated, every figure it links exists
//! and is non-empty, and a run that misses its expected outcome makes the exit code non-zero.
//!
//! The sweep starts `waggle run` children, which start the node binaries next to `waggle`:
//!
//! ```text
//! cargo build --release --workspace --bins
//! cargo test --release -p waggle-tests --test sweep                 # two short cases (≈ 3 min on 2 cores)
//! cargo test --release -p waggle-tests --test sweep -- --ignored    # every case, both modalities (≈ 40–95 min)
//! ```

use std::path::{Path, PathBuf};
use std::process::{Output, Stdio};

use serde_json::Value;
use waggle_tests::waggle_with_nodes as waggle;

fn out_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("waggle-sweep-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn text(o: &Output) -> String {
    format!(
        "status {}\nstdout:\n{}\nstderr:\n{}",
        o.status,
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// Every `](target)` link of a markdown file, relative to its directory.
fn links(md: &str) -> Vec<String> {
    md.split("](")
        .skip(1)
        .filter_map(|rest| rest.split(')').next())
        .map(str::to_string)
        .collect()
}

fn assert_figures_exist(dir: &Path, md: &str) -> usize {
    let links = links(md);
    for l in &links {
        let p = dir.join(l);
        let len = std::fs::metadata(&p)
            .unwrap_or_else(|e| panic!("{} linked from report.md: {e}", p.display()))
            .len();
        assert!(len > 0, "{} is empty", p.display());
    }
    links.len()
}

fn row<'a>(md: &'a str, label: &str) -> &'a str {
    md.lines()
        .find(|l| l.starts_with(&format!("| {label}")))
        .unwrap_or_else(|| panic!("no table row for {label}:\n{md}"))
}

#[test]
fn a_sweep_of_two_short_cases_writes_a_complete_report_and_a_failed_audit_fails() {
    let dir = out_dir("short");
    let out = waggle()
        .args([
            "sweep",
            "--case",
            "no-broadcast",
            "--case",
            "only-a",
            "--modality",
            "events",
            "--out",
        ])
        .arg(&dir)
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", text(&out));
    let md = std::fs::read_to_string(dir.join("report.md")).unwrap();
    assert_eq!(
        md.matches("audit from the recording").count(),
        2,
        "both runs audited from their session.mcap:\n{md}"
    );
    let n = assert_figures_exist(&dir, &md);
    // Two timelines, six symbol sheets (3 observers of only-a; no-broadcast decodes nothing but
    // its observers still publish a track), the sensor comparison.
    assert!(n >= 1 + 2 + 3, "{n} links:\n{md}");
    assert!(md.contains("figures/sensor-comparison.png"), "{md}");
    assert!(md.contains("figures/only-a-events-O1-symbols.svg"), "{md}");
    // The case table, ours beside the paper's.
    let r = row(&md, "No broadcast");
    assert!(r.contains("| not run | 0/0/0 | 0/0/0 |"), "{r}");
    assert!(r.contains("events PASS"), "{r}");
    let r = row(&md, "Only offer A");
    assert!(r.contains("| 1/1/1 | 1/1/1 |"), "{r}");
    assert!(r.contains("134.76"), "{r}");
    // The only-a symbol sheet shows the symbols of one frame (8 actions) over their templates.
    let sheet = std::fs::read_to_string(dir.join("figures/only-a-events-O1-symbols.svg")).unwrap();
    // One panel per symbol, captioned with its RMS error to the template (`E=`), the template
    // drawn dashed in grey (plotters writes each dash as its own grey polyline).
    assert!(sheet.matches(" E=").count() >= 8, "{sheet}");
    assert!(
        sheet.matches("stroke=\"#888888\"").count() >= 8 * 10,
        "{sheet}"
    );
    let manifest: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("sweep.json")).unwrap()).unwrap();
    assert_eq!(manifest["runs"].as_array().unwrap().len(), 2);
    let session: Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join("only-a-events/session.json")).unwrap(),
    )
    .unwrap();
    assert!(!session["performer"].as_array().unwrap().is_empty());

    // `waggle report` rebuilds the same report without re-running…
    let before = md.clone();
    let out = waggle()
        .args(["report", "--no-sensor-figure"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", text(&out));
    let again = std::fs::read_to_string(dir.join("report.md")).unwrap();
    assert_eq!(row(&again, "Only offer A"), row(&before, "Only offer A"));

    // …and fails when a run's counts no longer match its case (O2 lost its message). The
    // recording is the audit's source while it is there: without it the report falls back to
    // summary.json, which is what we alter.
    std::fs::remove_file(dir.join("only-a-events/session.mcap")).unwrap();
    let path = dir.join("only-a-events/summary.json");
    let mut s: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    s["observers"]["O2"]["complete_messages"] = Value::from(0);
    std::fs::write(&path, serde_json::to_string(&s).unwrap()).unwrap();
    let out = waggle()
        .args(["report", "--no-sensor-figure"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(!out.status.success(), "{}", text(&out));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("only-a-events"),
        "{}",
        text(&out)
    );
    let failed = std::fs::read_to_string(dir.join("report.md")).unwrap();
    assert!(row(&failed, "Only offer A").contains("**FAIL**"));
    assert!(failed.contains("complete messages [1, 0, 1], expected [1, 1, 1]"));
    assert!(failed.contains("(no session.mcap)"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_case_outside_its_modalities_is_skipped_and_nothing_to_run_is_an_error() {
    let dir = out_dir("skip");
    let out = waggle()
        .args([
            "sweep",
            "--case",
            "dropout-o2",
            "--modality",
            "rgb",
            "--out",
        ])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let all = text(&out);
    assert!(all.contains("dropout-o2 does not apply to rgb"), "{all}");
    assert!(all.contains("nothing to run"), "{all}");
}

#[test]
#[ignore = "every case in both modalities, one at a time ≈ 40–95 min on 2 cores: cargo test --release -p waggle-tests --test sweep -- --ignored"]
fn the_full_sweep_meets_every_expected_outcome() {
    let dir = out_dir("full");
    let out = waggle()
        .args(["sweep", "--out"])
        .arg(&dir)
        .stdin(Stdio::null())
        .output()
        .unwrap();
    let md = std::fs::read_to_string(dir.join("report.md")).unwrap_or_default();
    assert!(out.status.success(), "{}\n{md}", text(&out));
    assert_figures_exist(&dir, &md);
    for (label, rgb, events) in [
        ("1 observer", "4", "4"),
        ("2 observers", "4/4", "4/4"),
        ("3 observers", "4/4/4", "4/4/4"),
        ("O2 black input", "4/0/4", "4/0/4"),
        ("No broadcast", "0/0/0", "0/0/0"),
        ("Only offer A", "1/1/1", "1/1/1"),
    ] {
        let r = row(&md, label);
        assert!(
            r.contains(&format!("| {rgb} | {rgb} | {events} | {events} |")),
            "{r}"
        );
        assert!(r.contains("RGB PASS, events PASS"), "{r}");
    }
    let r = row(&md, "O2 stream dropout");
    assert!(r.contains("| not run | — | 4/0/4 | 4/0/4 |"), "{r}");
    assert!(!md.contains("FAIL"), "{md}");
}
