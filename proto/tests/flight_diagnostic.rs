//! Diagnostic for issue 28, item 3 (ignored: it needs recorded runs). Replays the image tracks
//! that a run's `observers.json` holds through the shared segmenter with the RGB receiver's
//! settings (the ideal baseline's chain), checks that the replay reproduces the recorded tokens
//! (interruptions aside: the observer core resets between rounds without one), and prints one
//! line per candidate path: stamp, outcome, template errors, margin, closure and span.
//!
//! `WAGGLE_DIAG_RUNS=/a/observers.json,/b/observers.json cargo test --release -p proto \
//!  --test flight_diagnostic -- --ignored --nocapture`

use proto::{Sample, SegmentToken, Segmenter, SegmenterConfig, Token, TokenCause};
use serde_json::Value;

fn token_name(t: Token) -> String {
    format!("{t:?}")
}

fn replay(track: &[Value]) -> Vec<SegmentToken> {
    let mut seg = Segmenter::new(SegmenterConfig::rgb()).expect("valid settings");
    let mut out = Vec::new();
    for s in track {
        let stamp_ns = s["stamp_ns"].as_u64().expect("stamp");
        let sample = match s["pos_px"].as_array() {
            Some(p) => Sample::tracked(
                stamp_ns,
                [p[0].as_f64().expect("x"), p[1].as_f64().expect("y")],
            ),
            None => Sample::lost(stamp_ns),
        };
        out.extend(seg.push(sample).expect("well-formed track"));
    }
    out
}

#[test]
#[ignore = "needs recorded runs: WAGGLE_DIAG_RUNS=<observers.json,…>"]
fn replay_recorded_tracks() {
    let runs = std::env::var("WAGGLE_DIAG_RUNS").expect("WAGGLE_DIAG_RUNS");
    for path in runs.split(',').filter(|p| !p.is_empty()) {
        let text = std::fs::read_to_string(path).expect("readable observers.json");
        let doc: Value = serde_json::from_str(&text).expect("json");
        for (name, obs) in doc.as_object().expect("observers") {
            let track = obs["track"].as_array().expect("track");
            let tokens = replay(track);
            let recorded: Vec<(String, u64)> = obs["tokens"]
                .as_array()
                .expect("tokens")
                .iter()
                .map(|t| {
                    (
                        t["token"].as_str().expect("token").to_owned(),
                        t["confirmed_ns"].as_u64().expect("stamp"),
                    )
                })
                .collect();
            // The observer core resets its segmenter between rounds (no token), where the
            // replay sees the performer's lost samples as an interruption.
            let replayed: Vec<(String, u64)> = tokens
                .iter()
                .filter(|t| !matches!(t.cause, TokenCause::Interrupted(_)))
                .map(|t| (token_name(t.token), t.stamp_ns))
                .collect();
            assert_eq!(replayed, recorded, "{path} {name}: replay differs");
            for t in &tokens {
                let line = match t.cause {
                    TokenCause::Classified(c) => format!(
                        "ok {:?} err {:.4} margin {:.4} closure {:.4} span {:.1} errors {:.4?}",
                        c.action,
                        c.error,
                        c.runner_up_error - c.error,
                        c.closure,
                        c.span_px,
                        c.errors
                    ),
                    TokenCause::Rejected(r) => format!("rejected {r:?}"),
                    TokenCause::Interrupted(i) => format!("interrupted {i:?}"),
                    TokenCause::Overlong { motion_ns } => format!("overlong {motion_ns}"),
                    TokenCause::External => "external".to_owned(),
                    TokenCause::Rest => continue,
                };
                println!("DIAG\t{path}\t{name}\t{}\t{line}", t.stamp_ns);
            }
        }
    }
}
