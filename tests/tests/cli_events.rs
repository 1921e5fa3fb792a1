//! `waggle events convert`, run as the built binary on PNG frames written to a temp directory.
//!
//! Proves frames are converted in name order into the CSV the library's converter produces, that
//! threshold and frame rate are honoured, and that bad input (no frames, mixed sizes, an
//! unreadable PNG, bad arguments) fails naming the problem.

use std::path::{Path, PathBuf};
use std::process::Output;

use event_camera::picture::{encode_png, from_rgb};
use event_camera::{Converter, Polarity};

/// A fresh, empty directory for one test.
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("cli_events")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn write_frame(dir: &Path, name: &str, width: u32, height: u32, rgb: Vec<u8>) {
    let png = encode_png(&from_rgb(width, height, rgb).unwrap()).unwrap();
    std::fs::write(dir.join(name), png).unwrap();
}

fn waggle(args: &[&str]) -> Output {
    waggle_tests::waggle()
        .args(args)
        .output()
        .expect("spawn waggle")
}

fn convert(frames: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["events", "convert", "--fps", "100", "--in"];
    args.push(frames.to_str().unwrap());
    args.extend(["--out", out.to_str().unwrap()]);
    args.extend(extra);
    waggle(&args)
}

fn gray_strip(values: &[u8]) -> Vec<u8> {
    values.iter().flat_map(|&v| [v; 3]).collect()
}

#[test]
fn converts_frames_sorted_by_name_into_csv() {
    let dir = scratch("sorted");
    // Written out of order; names decide the order. A non-PNG file is ignored.
    write_frame(&dir, "f2.png", 3, 1, gray_strip(&[165, 60, 100]));
    write_frame(&dir, "f0.png", 3, 1, gray_strip(&[100, 100, 100]));
    write_frame(&dir, "f1.png", 3, 1, gray_strip(&[165, 100, 100]));
    std::fs::write(dir.join("notes.txt"), "not a frame").unwrap();
    let out = dir.join("events.csv");
    let run = convert(&dir, &out, &[]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );

    let csv = std::fs::read_to_string(&out).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("t_ns,x,y,p"));
    let rows: Vec<&str> = lines.collect();
    // f0 → f1: pixel 0 rises by ln 1.65 (two ON at 0.18, 0.36); f1 → f2: pixel 1 falls by
    // ln(100/60) = 0.51 (two OFF), with times from the 10 ms frame spacing.
    assert_eq!(rows[0], "3594427,0,0,1");
    assert_eq!(rows.len(), 4, "{csv}");
    assert!(rows[1].ends_with(",0,0,1"));
    assert!(
        rows[2].starts_with("1") && rows[2].ends_with(",1,0,-1"),
        "{csv}"
    );
    assert!(rows[3].ends_with(",1,0,-1"));

    // Exactly the library's event stream.
    let mut conv = Converter::new(3, 1, 0.18).unwrap();
    let mut want = Vec::new();
    for (k, values) in [[100, 100, 100], [165, 100, 100], [165, 60, 100]]
        .iter()
        .enumerate()
    {
        conv.push(k as u64 * 10_000_000, &gray_strip(values), &mut want)
            .unwrap();
    }
    let want: Vec<String> = want
        .iter()
        .map(|e| {
            format!(
                "{},{},{},{}",
                e.t_ns,
                e.x,
                e.y,
                if e.polarity == Polarity::On { 1 } else { -1 }
            )
        })
        .collect();
    assert_eq!(rows, want);

    let stdout = String::from_utf8(run.stdout).unwrap();
    assert_eq!(stdout.lines().count(), 1, "one-line summary: {stdout}");
    assert!(
        stdout.contains("3 frames 3x1: 4 events (ON 2, OFF 2)"),
        "{stdout}"
    );
    assert!(stdout.contains("ms per frame"), "{stdout}");
    assert!(!dir.join("events.csv.partial").exists());
}

#[test]
fn threshold_and_fps_are_honoured() {
    let dir = scratch("threshold");
    write_frame(&dir, "a.png", 1, 1, gray_strip(&[100]));
    write_frame(&dir, "b.png", 1, 1, gray_strip(&[165]));
    let out = dir.join("events.csv");
    let run = waggle(&[
        "events",
        "convert",
        "--fps",
        "25",
        "--in",
        dir.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--threshold",
        "0.1",
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let csv = std::fs::read_to_string(&out).unwrap();
    let times: Vec<u64> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(times.len(), 5, "ln 1.65 / 0.1 → 5 crossings: {csv}");
    // At 25 fps the interval is 40 ms: the last crossing (0.5 of 0.5008) is just before 40 ms.
    assert!(times.iter().all(|&t| t > 0 && t <= 40_000_000));
    assert!(times[4] > 39_000_000, "{csv}");
}

#[test]
fn a_single_frame_gives_a_header_only() {
    let dir = scratch("single");
    write_frame(&dir, "only.png", 2, 2, vec![50; 12]);
    let out = dir.join("events.csv");
    let run = convert(&dir, &out, &[]);
    assert!(run.status.success());
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "t_ns,x,y,p\n");
    assert!(String::from_utf8_lossy(&run.stdout).contains("1 frames 2x2: 0 events"));
}

fn assert_fails_naming(run: &Output, needle: &str) {
    assert!(!run.status.success(), "unexpected success");
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        stderr.contains(needle),
        "stderr does not name {needle:?}: {stderr}"
    );
}

#[test]
fn no_frames_is_an_error() {
    let dir = scratch("empty");
    std::fs::write(dir.join("readme.txt"), "x").unwrap();
    let out = scratch("empty_out").join("events.csv");
    let run = convert(&dir, &out, &[]);
    assert_fails_naming(&run, "no PNG frames");
    assert_fails_naming(&run, dir.to_str().unwrap());
    assert!(!out.exists());
    let missing = dir.join("does-not-exist");
    assert_fails_naming(&convert(&missing, &out, &[]), "does-not-exist");
}

#[test]
fn mixed_sizes_name_the_odd_frame() {
    let dir = scratch("mixed");
    write_frame(&dir, "f0.png", 4, 3, vec![10; 36]);
    write_frame(&dir, "f1.png", 4, 3, vec![20; 36]);
    write_frame(&dir, "f2.png", 3, 4, vec![20; 36]);
    let out = dir.join("events.csv");
    let run = convert(&dir, &out, &[]);
    assert_fails_naming(&run, "f2.png");
    assert_fails_naming(&run, "3x4");
    assert!(!out.exists(), "no partial output on failure");
    assert!(!dir.join("events.csv.partial").exists());
}

#[test]
fn unreadable_png_names_the_file() {
    let dir = scratch("corrupt");
    write_frame(&dir, "f0.png", 2, 2, vec![10; 12]);
    std::fs::write(dir.join("f1.png"), b"\x89PNG\r\n\x1a\n truncated").unwrap();
    let out = dir.join("events.csv");
    let run = convert(&dir, &out, &[]);
    assert_fails_naming(&run, "f1.png");
    assert!(!out.exists());
}

#[test]
fn bad_arguments_are_rejected() {
    let dir = scratch("args");
    write_frame(&dir, "f0.png", 1, 1, vec![10; 3]);
    let out = dir.join("events.csv");
    assert!(
        !waggle(&[
            "events",
            "convert",
            "--fps",
            "0",
            "--in",
            dir.to_str().unwrap(),
            "--out",
            out.to_str().unwrap()
        ])
        .status
        .success()
    );
    assert_fails_naming(&convert(&dir, &out, &["--threshold", "0"]), "threshold");
    assert!(!out.exists());
}
