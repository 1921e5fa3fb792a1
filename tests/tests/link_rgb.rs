//! `waggle link --modality rgb` on the real MuJoCo scene: the KLT receiver against the ideal
//! receiver of the same flight.
//!
//! Proves the RGB receiver releases the same payloads at the ideal token times (within one frame
//! and a bit), decodes a sweep of payloads for every observer (`deploy/test.sh --full`), and that
//! a blacked-out observer releases nothing while the others are unaffected.

mod common;
use common::{NOMINAL_PAYLOADS, assert_matches_ideal, link, nominal_link, payloads, tokens};

/// 40 ms frames make offsets multiples of 0.04 s; allow for float noise on the 0.2 s bound.
const TOLERANCE_S: f64 = 0.2 + 1e-9;

#[test]
fn rgb_releases_the_nominal_payloads_at_ideal_token_times() {
    let v = nominal_link("rgb");
    for o in ["O1", "O2", "O3"] {
        assert_eq!(payloads(&v, o), NOMINAL_PAYLOADS, "{o}");
        let worst = assert_matches_ideal(&v, o, TOLERANCE_S);
        println!("{o}: worst token offset from the ideal receiver {worst:.3} s");
    }
}

/// A representative sweep instead of all 64 payloads (64 offers would be ~105 min of sim time):
/// every bit position carries both values, plus both invalid site ids (00, 11) — the link decodes
/// frames, validity is the agent's business.
#[test]
#[ignore = "six offers at three viewpoints, ≈ 2.5 min: deploy/test.sh --full (the default run \
            decodes the three nominal payloads at the same viewpoints)"]
fn a_sweep_of_payloads_decodes_for_every_observer() {
    let sweep = ["000000", "111111", "010101", "101010", "001100", "110011"];
    let mut args = vec!["--observers", "3", "--modality", "rgb"];
    for p in &sweep {
        args.extend(["--payload", p]);
    }
    let v = link(&args);
    for o in ["O1", "O2", "O3"] {
        assert_eq!(payloads(&v, o), sweep, "{o}");
    }
}

#[test]
fn a_blacked_out_observer_releases_nothing_and_the_others_are_unaffected() {
    let v = link(&[
        "--observers",
        "3",
        "--modality",
        "rgb",
        "--black",
        "O2",
        "--payload",
        "010000",
    ]);
    assert!(payloads(&v, "O2").is_empty());
    let nulls = tokens(&v, "observers", "O2")
        .iter()
        .filter(|t| t.0 == "NULL")
        .count();
    assert!(nulls <= 1, "O2 confirmed {nulls} NULLs on black input");
    for o in ["O1", "O3"] {
        assert_eq!(payloads(&v, o), ["010000"], "{o}");
    }
}
