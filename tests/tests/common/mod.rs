//! Helpers shared by the `waggle link` tests (`link.rs`, `link_events.rs`, `link_rgb.rs`): run
//! `waggle link --json` and read payloads and token times out of its output.

use serde_json::Value;

/// The three offers of the paper's nominal broadcast, in order.
pub const NOMINAL_PAYLOADS: [&str; 3] = ["011010", "100111", "010000"];

/// `waggle link` with three observers on `modality`'s receiver and the nominal payloads.
#[allow(dead_code, reason = "link.rs uses only the other helpers")]
pub fn nominal_link(modality: &str) -> Value {
    let mut args = vec!["--observers", "3", "--modality", modality];
    for p in NOMINAL_PAYLOADS {
        args.extend(["--payload", p]);
    }
    link(&args)
}

/// Runs `waggle link ARGS --json` and parses its output; panics with stderr on failure.
pub fn link(args: &[&str]) -> Value {
    let out = waggle_tests::succeed(
        waggle_tests::waggle().arg("link").args(args).arg("--json"),
        &format!("waggle link {args:?}"),
    );
    serde_json::from_slice(&out.stdout).expect("JSON output")
}

/// Released payloads of one observer.
pub fn payloads(v: &Value, observer: &str) -> Vec<String> {
    v["observers"][observer]["payloads"]
        .as_array()
        .unwrap_or_else(|| panic!("no payloads for {observer}: {v}"))
        .iter()
        .map(|p| p.as_str().expect("string").to_string())
        .collect()
}

/// (token, time) pairs of one observer, from `section` ("observers" or "ideal").
pub fn tokens(v: &Value, section: &str, observer: &str) -> Vec<(String, f64)> {
    v[section][observer]["tokens"]
        .as_array()
        .unwrap_or_else(|| panic!("no {section} tokens for {observer}"))
        .iter()
        .map(|t| {
            (
                t["token"].as_str().unwrap().to_string(),
                t["t_s"].as_f64().unwrap(),
            )
        })
        .collect()
}

/// Asserts the receiver produced exactly the ideal receiver's token sequence, each token within
/// `tolerance_s` of the ideal one; returns the largest offset.
#[allow(dead_code)]
pub fn assert_matches_ideal(v: &Value, observer: &str, tolerance_s: f64) -> f64 {
    let real = tokens(v, "observers", observer);
    let ideal = tokens(v, "ideal", observer);
    let names = |t: &[(String, f64)]| t.iter().map(|x| x.0.clone()).collect::<Vec<_>>();
    assert_eq!(
        names(&real),
        names(&ideal),
        "{observer}: token sequences differ"
    );
    let mut worst: f64 = 0.0;
    for ((tok, t), (_, ti)) in real.iter().zip(&ideal) {
        let d = (t - ti).abs();
        worst = worst.max(d);
        assert!(
            d <= tolerance_s,
            "{observer}: {tok} at {t:.3} s, ideal {ti:.3} s"
        );
    }
    worst
}
