//! `waggle link` end to end on the real MuJoCo scene.
//!
//! Proves the ideal receiver releases the nominal offers for every observer in order with the
//! performer tracking its path, that a blacked-out observer leaves the others unaffected, and that
//! malformed payloads and unknown observers are rejected with a message, as are unknown sensor
//! presets; and that event cameras under v2e's default sensor model still decode an offer.

mod common;
use common::{link, payloads};

#[test]
fn ideal_link_releases_both_nominal_offers_for_every_observer_in_order() {
    let v = link(&[
        "--observers",
        "3",
        "--modality",
        "ideal",
        "--payload",
        "011010",
        "--payload",
        "100111",
    ]);
    for o in ["O1", "O2", "O3"] {
        assert_eq!(payloads(&v, o), ["011010", "100111"], "{o}");
        let tokens = v["observers"][o]["tokens"].as_array().unwrap();
        assert_eq!(
            tokens.len(),
            33,
            "{o}: 17 + 16 tokens (the shared hover closes one and opens the next)"
        );
    }
    let err = v["performer_max_tracking_error_m"].as_f64().unwrap();
    assert!(err < 0.01, "performer tracking error {err} m");
    assert_eq!(v["contact_steps"], 0);
}

#[test]
fn ideal_link_with_a_blacked_out_observer_leaves_the_others_unaffected() {
    let v = link(&["--observers", "3", "--payload", "010000", "--black", "O2"]);
    assert_eq!(payloads(&v, "O1"), ["010000"]);
    assert!(payloads(&v, "O2").is_empty());
    assert_eq!(payloads(&v, "O3"), ["010000"]);
}

#[test]
fn link_rejects_malformed_payloads_and_unknown_observers_with_a_message() {
    for (args, needle) in [
        (vec!["--payload", "01101"], "six binary digits"),
        (vec!["--payload", "01102x"], "six binary digits"),
        (
            vec!["--payload", "011010", "--black", "O9"],
            "no such observer",
        ),
        (
            vec!["--modality", "events", "--sensor-preset", "v2e-loud"],
            "v2e-loud",
        ),
        (
            vec!["--modality", "events", "--sensor-preset", "v2e-loud"],
            "v2e-default",
        ),
        (
            vec!["--modality", "events", "--perturb", "link.drop_rate=0.1"],
            "link.drop_rate",
        ),
        (
            vec!["--modality", "rgb", "--sensor-preset", "v2e-clean"],
            "rgb",
        ),
    ] {
        let out = waggle_tests::waggle()
            .arg("link")
            .args(&args)
            .output()
            .unwrap();
        assert!(!out.status.success(), "{args:?} accepted");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}

#[test]
fn an_event_link_under_the_v2e_default_sensor_preset_decodes_and_records_it() {
    // ≈ 7 s on 2 cores: one observer, one offer, every render through the noisy sensor.
    let v = link(&[
        "--observers",
        "1",
        "--modality",
        "events",
        "--payload",
        "011010",
        "--sensor-preset",
        "v2e-default",
        "--seed",
        "2",
    ]);
    assert_eq!(v["sensor"]["preset"], "v2e-default");
    assert_eq!(v["sensor"]["seed"], 2);
    assert!(
        v["sensor"]["perturb"]["events.shot_noise_hz"]
            .as_f64()
            .unwrap()
            > 0.0
    );
    assert_eq!(payloads(&v, "O1"), ["011010"]);
}

#[test]
fn a_negative_azimuth_is_accepted_without_an_equals_sign() {
    // `--viewpoint -20,0,1.6` must not be read as a flag `-2`.
    let v = link(&[
        "--viewpoint",
        "-20,0,1.6",
        "--modality",
        "ideal",
        "--payload",
        "011010",
    ]);
    assert_eq!(payloads(&v, "O1"), ["011010"]);
}
