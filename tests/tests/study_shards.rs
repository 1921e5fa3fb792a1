//! Studies and trials split into shards, resumed after a kill, merged: `waggle study --shard K/N`
//! and `waggle trials --shard K/N` run disjoint blocks of the trials, `waggle study merge` writes
//! the very bytes one process writes (study.json, every trials.json, report.md, the figures),
//! a shard killed with SIGKILL resumes running only its missing trials (a damaged record is
//! rerun), and merging refuses what is not one run. Shards on one host share a render cache on
//! disk (`--render-cache`): one of them flies a flight, the others read it.

use std::path::{Path, PathBuf};
use std::process::{Output, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;

/// A fresh directory for one test (the process id keeps concurrent runs apart).
fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("waggle-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn waggle(args: &[&str], what: &str) -> Output {
    waggle_tests::succeed(waggle_tests::waggle().args(args), what)
}

fn s(p: &Path) -> &str {
    p.to_str().expect("UTF-8 path")
}

fn read_json(path: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(path).unwrap_or_else(|e| panic!("{path:?}: {e}")))
        .expect("JSON")
}

/// Fails unless `file` holds the same bytes in both directories.
fn assert_same(a: &Path, b: &Path, file: &str) {
    let (x, y) = (std::fs::read(a.join(file)), std::fs::read(b.join(file)));
    let (x, y) = (
        x.unwrap_or_else(|e| panic!("{file} in {a:?}: {e}")),
        y.unwrap_or_else(|e| panic!("{file} in {b:?}: {e}")),
    );
    assert!(x == y, "{file} differs between {a:?} and {b:?}");
}

/// The record files of a point (or of a trials directory), by name.
fn records(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir.join("trials"))
        .map(|d| {
            d.flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.ends_with(".json"))
                .collect()
        })
        .unwrap_or_default();
    names.sort();
    names
}

/// Two conditions × both modalities, two trials per point: 6 points, 12 trials, one shared
/// flight (no term re-flies).
fn study() -> String {
    waggle_tests::two_condition_study("shards", 11)
}

/// Starts shard `k`/3 of `file` into `out` and SIGKILLs it as soon as `point` holds one record.
fn kill_after_first_record(file: &Path, out: &Path, k: u64, point: &str) {
    let mut child = waggle_tests::waggle()
        .args([
            "study",
            s(file),
            "--jobs",
            "1",
            "--shard",
            &format!("{k}/3"),
        ])
        .arg("--out")
        .arg(out)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while records(&out.join(point)).is_empty() {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the shard ended before it was killed"
        );
        assert!(started.elapsed() < Duration::from_secs(300), "no record");
        std::thread::sleep(Duration::from_millis(20));
    }
    child.kill().unwrap(); // SIGKILL: nothing runs after it
    child.wait().unwrap();
}

#[test]
#[ignore = "a study in one process and in three shards, ≈ 2 min: deploy/test.sh --full"]
fn shards_resumed_after_a_kill_merge_to_the_single_run_byte_for_byte() {
    let dir = tmp("study-shards");
    let file = dir.join("shards.toml");
    std::fs::write(&file, study()).unwrap();
    let single = dir.join("single");
    waggle(
        &["study", s(&file), "--jobs", "2", "--out", s(&single)],
        "the study in one process",
    );

    // Shard 2/3 holds the four trials of read noise 30 (RGB then events): killed after its first
    // record, one more record damaged by hand... then resumed.
    let shard = |k: u64| dir.join(format!("shard-{k}"));
    let point = "rgb-rgb.read_noise_grey-30";
    kill_after_first_record(&file, &shard(2), 2, point);
    let before = records(&shard(2).join(point));
    let kept = shard(2).join(point).join("trials").join(&before[0]);
    let kept_bytes = std::fs::read(&kept).unwrap();
    let kept_time = std::fs::metadata(&kept).unwrap().modified().unwrap();
    let damaged = shard(2).join("events-rgb.read_noise_grey-30/trials/000001.json");
    std::fs::create_dir_all(damaged.parent().unwrap()).unwrap();
    std::fs::write(&damaged, b"{\"body\": {\"format\": \"waggle-tri").unwrap();
    let mut shards = Vec::new();
    for k in 1..=3 {
        let out = waggle(
            &[
                "study",
                s(&file),
                "--jobs",
                "2",
                "--shard",
                &format!("{k}/3"),
                "--out",
                s(&shard(k)),
            ],
            &format!("shard {k}/3"),
        );
        let text = String::from_utf8_lossy(&out.stdout).into_owned();
        if k == 2 {
            // Nothing recorded ran again; everything missing (and the damaged one) did.
            let recorded = before.len();
            let ran = 4 - recorded;
            assert!(
                text.contains(&format!(
                    "4 trials in this part: {ran} ran now, {recorded} already recorded"
                )) && text.contains("1 damaged records set aside and rerun"),
                "{text}"
            );
            assert_eq!(std::fs::read(&kept).unwrap(), kept_bytes);
            assert_eq!(
                std::fs::metadata(&kept).unwrap().modified().unwrap(),
                kept_time
            );
            assert!(damaged.with_extension("json.damaged").exists());
        }
        shards.push(shard(k));
    }
    // Rerunning a finished shard runs nothing.
    let again = waggle(
        &["study", s(&file), "--shard", "1/3", "--out", s(&shard(1))],
        "shard 1/3 again",
    );
    assert!(
        String::from_utf8_lossy(&again.stdout).contains("0 ran now, 4 already recorded"),
        "{}",
        String::from_utf8_lossy(&again.stdout)
    );

    // Two of three shards: refused, naming the missing one.
    let merged = dir.join("merged");
    let out = waggle_tests::waggle()
        .args([
            "study",
            "merge",
            s(&shards[0]),
            s(&shards[2]),
            "--out",
            s(&merged),
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("shard 2/3"), "{err}");

    let mut args = vec!["study", "merge"];
    args.extend(shards.iter().map(|p| s(p)));
    args.extend(["--out", s(&merged)]);
    waggle(&args, "waggle study merge");
    let points = read_json(&single.join("study.json"));
    assert_eq!(points.as_array().unwrap().len(), 6);
    for f in [
        "study.json",
        "report.md",
        "provenance.json",
        "success-rgb.read_noise_grey.svg",
        "success-events.shot_noise_hz.svg",
    ] {
        assert_same(&single, &merged, f);
    }
    for p in points.as_array().unwrap() {
        let d = p["dir"].as_str().unwrap();
        assert_same(&single, &merged, &format!("{d}/trials.json"));
        assert_eq!(read_json(&merged.join(d).join("trials.json"))["trials"], 2);
    }
    // Costs are summed: each shard's run (shard 2's resumed one; the killed run wrote none) and shard 1's second run.
    let cost = read_json(&merged.join("cost.json"));
    assert_eq!(cost["runs"], 4, "{cost}");
    let report = std::fs::read_to_string(merged.join("report.md")).unwrap();
    assert!(
        !report.contains("core-s"),
        "report.md holds no measured time"
    );
    assert!(
        std::fs::read_to_string(merged.join("cost.md"))
            .unwrap()
            .contains("core-s per trial")
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn trials_shards_merge_to_the_single_run_and_a_rerun_resumes() {
    let dir = tmp("trials-shards");
    let base = [
        "trials",
        "--link",
        "011010",
        "--observers",
        "1",
        "--modality",
        "rgb",
        "--trials",
        "3",
        "--seed",
        "3",
        "--perturb",
        "rgb.read_noise_grey=20",
        "--jobs",
        "2",
    ];
    let run = |extra: &[&str], out: &Path| {
        let mut args = base.to_vec();
        args.extend_from_slice(extra);
        args.extend(["--out", s(out)]);
        waggle(&args, &format!("waggle {args:?}"))
    };
    let single = dir.join("single");
    run(&[], &single);
    // The two shards at once on this host, sharing a render cache: one flies the broadcast, the
    // other waits for it and reads it; results as without the cache.
    let (a, b) = (dir.join("a"), dir.join("b"));
    let cache = dir.join("render-cache");
    let outs: Vec<String> = std::thread::scope(|scope| {
        let shards = [("1/2", &a), ("2/2", &b)].map(|(k, out)| {
            let cache = s(&cache);
            scope.spawn(move || run(&["--shard", k, "--render-cache", cache], out))
        });
        shards
            .map(|h| String::from_utf8_lossy(&h.join().unwrap().stdout).into_owned())
            .to_vec()
    });
    let from_cache = outs
        .iter()
        .filter(|o| o.contains("1 flight(s) (1 from the render cache)"))
        .count();
    assert_eq!(from_cache, 1, "{outs:?}");
    let entries = std::fs::read_dir(&cache)
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().ends_with(".renders"))
        .count();
    assert_eq!(entries, 1);
    assert_eq!(records(&a), ["000000.json"]);
    assert_eq!(records(&b), ["000001.json", "000002.json"]);
    let merged = dir.join("merged");
    waggle(
        &["study", "merge", s(&a), s(&b), "--out", s(&merged)],
        "merge",
    );
    assert_same(&single, &merged, "trials.json");
    assert_eq!(read_json(&merged.join("cost.json"))["trials_run"], 3);

    // A damaged record of the single run: detected, set aside, rerun, same bytes again.
    let rec = single.join("trials/000001.json");
    let text = std::fs::read_to_string(&rec).unwrap();
    std::fs::write(&rec, text.replacen("\"tokens\":", "\"tokens\": 1", 1)).unwrap();
    let out = run(&[], &single);
    assert!(
        String::from_utf8_lossy(&out.stdout)
            .contains("1 trials ran, 2 already recorded, 1 damaged"),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    assert_same(&single, &merged, "trials.json");

    // Another condition in the same directory, a different shard, shards of different runs: refused.
    let mut other = base.to_vec();
    other[12] = "rgb.read_noise_grey=21";
    other.extend(["--out", s(&single)]);
    let out = waggle_tests::waggle().args(&other).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("another definition"),
        "{err}"
    );
    let out = waggle_tests::waggle()
        .args(base)
        .args(["--shard", "2/2", "--out", s(&a)])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("shard 1/2, not 2/2"),
        "{err}"
    );
    let out = waggle_tests::waggle()
        .args([
            "study",
            "merge",
            s(&a),
            s(&single),
            "--out",
            s(&dir.join("m2")),
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("not parts of the same run"),
        "{err}"
    );
    let out = waggle_tests::waggle()
        .args(["study", "merge", s(&a), "--out", s(&dir.join("m3"))])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("1 of 3 trials") && err.contains("2/2"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn shard_arguments_are_checked_and_cluster_files_written() {
    let dir = tmp("shard-args");
    for (args, needle) in [
        (vec!["--shard", "0/4"], "between 1 and N"),
        (vec!["--shard", "5/4"], "5/4"),
        (vec!["--shard", "two/4"], "two"),
        (vec!["--shard-from-env"], "SLURM_ARRAY_TASK_ID"),
    ] {
        let out = waggle_tests::waggle()
            .args(["study", "event-noise", "--out", s(&dir.join("x"))])
            .args(&args)
            .env_remove("SLURM_ARRAY_TASK_ID")
            .env_remove("JOB_COMPLETION_INDEX")
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && err.contains(needle),
            "{args:?}: {err}"
        );
    }
    let out = waggle(
        &[
            "study",
            "event-noise",
            "--trials",
            "4",
            "--slurm",
            "--shard-count",
            "4",
            "--partition",
            "batch",
            "--time",
            "01:00:00",
            "--mem",
            "4G",
            "--cpus-per-task",
            "2",
            "--kubernetes",
            "registry.example/waggle:1",
            "--render-cache",
            "/scratch/waggle-renders",
            "--waggle",
            "/opt/waggle/bin/waggle",
            "--out",
            s(&dir),
        ],
        "--slurm",
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("submit.sh"));
    let array = std::fs::read_to_string(dir.join("slurm/array.sbatch")).unwrap();
    for needle in [
        "--array=0-3",
        "--partition=batch",
        "--time=01:00:00",
        "--mem=4G",
        "--cpus-per-task=2",
        "exec /opt/waggle/bin/waggle study",
        "--render-cache /scratch/waggle-renders",
    ] {
        assert!(array.contains(needle), "{needle}: {array}");
    }
    let toml = std::fs::read_to_string(dir.join("study.toml")).unwrap();
    assert!(toml.contains("trials = 4"), "{toml}");
    assert!(dir.join("kubernetes/study-job.yaml").exists());
    assert!(!dir.join("run.json").exists(), "--slurm runs nothing");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
#[ignore = "a crossed study in one process and in two shards, ≈ 2 min: deploy/test.sh --full"]
fn a_crossed_study_is_laid_out_per_factor_and_merges_byte_for_byte() {
    let dir = tmp("study-crossed");
    let file = dir.join("crossed.toml");
    let crossed = study()
        .replace("name = \"shards\"", "name = \"crossed\"\ncross = true")
        .replace("levels = [0.0003]", "levels = [0.0, 0.0003]")
        .replace("trials = 2", "trials = 1");
    std::fs::write(&file, crossed).unwrap();
    let single = dir.join("single");
    waggle(
        &["study", s(&file), "--jobs", "2", "--out", s(&single)],
        "the crossed study in one process",
    );
    let (a, b) = (dir.join("a"), dir.join("b"));
    for (k, out) in [("1/2", &a), ("2/2", &b)] {
        waggle(
            &[
                "study",
                s(&file),
                "--jobs",
                "2",
                "--shard",
                k,
                "--out",
                s(out),
            ],
            &format!("crossed shard {k}"),
        );
    }
    let merged = dir.join("merged");
    waggle(
        &["study", "merge", s(&a), s(&b), "--out", s(&merged)],
        "merge",
    );
    let points = read_json(&single.join("study.json"));
    let points = points.as_array().unwrap();
    assert_eq!(points.len(), 2 * 2 * 2, "2 × 2 levels × 2 modalities");
    assert_eq!(points[0]["factors"]["rgb.read_noise_grey"], 0.0);
    for f in [
        "study.json",
        "report.md",
        "success-rgb.read_noise_grey.svg",
        "success-events.shot_noise_hz.svg",
    ] {
        assert_same(&single, &merged, f);
    }
    for p in points {
        assert_same(
            &single,
            &merged,
            &format!("{}/trials.json", p["dir"].as_str().unwrap()),
        );
    }
    let report = std::fs::read_to_string(single.join("report.md")).unwrap();
    assert!(
        report.contains("Crossed") && report.matches("Every combination:").count() == 4,
        "{report}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A baselines study (whole missions per case × arm × level): three shards, one of them
/// rerun after a record was damaged, merge to the single run byte for byte; a rerun of the
/// single run flies nothing.
#[test]
fn a_baselines_study_in_shards_merges_to_the_single_run_byte_for_byte() {
    let dir = tmp("baselines-shards");
    let file = dir.join("b.toml");
    std::fs::write(
        &file,
        "name = \"bl\"\ncases = [\"only-a\"]\narms = [\"ideal\", \"fixed\"]\ntrials = 2\n\
         seed = 3\n[[vary]]\nkey = \"flight.gust_sigma_n\"\nlevels = [0.0, 0.004]\n",
    )
    .unwrap();
    let single = dir.join("single");
    waggle(
        &["study", s(&file), "--jobs", "2", "--out", s(&single)],
        "single",
    );
    let out = waggle(&["study", s(&file), "--out", s(&single)], "rerun");
    assert!(
        String::from_utf8_lossy(&out.stdout).contains("0 flown now, 8 already recorded"),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    let shards: Vec<PathBuf> = (1..=3).map(|k| dir.join(format!("shard-{k}"))).collect();
    for (k, d) in shards.iter().enumerate() {
        let shard = format!("{}/3", k + 1);
        waggle(
            &["study", s(&file), "--shard", &shard, "--out", s(d)],
            &shard,
        );
    }
    // Shard 2 (missions 2..5: both of the second point's, the third point's first) has a
    // record damaged: its rerun flies that mission again.
    let rec = shards[1].join("only-a-fixed-allocation-flight.gust_sigma_n-0/trials/000000.json");
    let text = std::fs::read_to_string(&rec).unwrap();
    std::fs::write(&rec, text.replacen("\"seed\":", "\"seed\": 1", 1)).unwrap();
    let out = waggle(
        &["study", s(&file), "--shard", "2/3", "--out", s(&shards[1])],
        "rerun of shard 2",
    );
    assert!(
        String::from_utf8_lossy(&out.stdout).contains("1 flown now"),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    let merged = dir.join("merged");
    let mut args = vec!["study", "merge"];
    args.extend(shards.iter().map(|d| s(d)));
    args.extend(["--out", s(&merged)]);
    waggle(&args, "merge");
    let mut files = vec![
        "study.json".to_string(),
        "report.md".into(),
        "success-only-a-flight.gust_sigma_n.svg".into(),
    ];
    for arm in ["ideal-message", "fixed-allocation"] {
        for level in ["0", "0.004"] {
            files.push(format!(
                "only-a-{arm}-flight.gust_sigma_n-{level}/trials.json"
            ));
        }
    }
    for f in &files {
        assert_same(&single, &merged, f);
    }
    let study = read_json(&merged.join("study.json"));
    assert_eq!(study.as_array().map(Vec::len), Some(4));
    // cost.json sums every run of every shard: 8 missions, and the one flown again.
    assert_eq!(read_json(&merged.join("cost.json"))["trials_run"], 9);
    // Two shards only: refused, naming the missing one.
    let out = waggle_tests::waggle()
        .args(["study", "merge", s(&shards[0]), s(&shards[1]), "--out"])
        .arg(dir.join("m2"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("3/3"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `waggle trials --case` (whole missions of one case) in two shards merges to the single run;
/// a rerun flies nothing.
#[test]
fn case_trials_in_shards_merge_to_the_single_run() {
    let dir = tmp("case-shards");
    let base = [
        "trials",
        "--case",
        "only-a",
        "--modality",
        "ideal",
        "--trials",
        "3",
        "--seed",
        "5",
        "--perturb",
        "flight.gust_sigma_n=0.004",
    ];
    let run = |extra: &[&str], out: &Path| {
        let mut args = base.to_vec();
        args.extend_from_slice(extra);
        args.extend(["--out", s(out)]);
        waggle(&args, &format!("waggle {args:?}"))
    };
    let single = dir.join("single");
    run(&[], &single);
    let again = run(&[], &single);
    assert!(
        String::from_utf8_lossy(&again.stdout).contains("0 missions flown, 3 already recorded"),
        "{}",
        String::from_utf8_lossy(&again.stdout)
    );
    let (a, b) = (dir.join("a"), dir.join("b"));
    run(&["--shard", "1/2"], &a);
    run(&["--shard", "2/2"], &b);
    assert_eq!(records(&a), ["000000.json"]);
    assert_eq!(records(&b), ["000001.json", "000002.json"]);
    let merged = dir.join("merged");
    waggle(
        &["study", "merge", s(&a), s(&b), "--out", s(&merged)],
        "merge",
    );
    assert_same(&single, &merged, "trials.json");
    assert_eq!(read_json(&merged.join("trials.json"))["trials"], 3);
    assert_eq!(read_json(&merged.join("cost.json"))["trials_run"], 3);
    let _ = std::fs::remove_dir_all(&dir);
}
