//! The `waggle payload` and `waggle allocate` subcommands, run as the built binary.
//!
//! Proves `payload decode`/`encode` print (and round-trip) the paper's offers, `allocate`
//! reproduces the paper's allocations, and bad input is rejected with a reason on stderr and
//! nothing on stdout.

use std::process::Output;

fn waggle(args: &[&str]) -> Output {
    waggle_tests::waggle()
        .args(args)
        .output()
        .expect("spawn waggle")
}

/// Runs a command expected to succeed; returns its trimmed stdout.
fn ok(args: &[&str]) -> String {
    let out = waggle(args);
    assert!(
        out.status.success(),
        "waggle {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout)
        .expect("utf-8 stdout")
        .trim()
        .to_owned()
}

/// Runs a command expected to fail; returns its stderr.
fn fails(args: &[&str]) -> String {
    let out = waggle(args);
    assert!(
        !out.status.success(),
        "waggle {args:?} unexpectedly succeeded"
    );
    assert!(out.stdout.is_empty(), "a failed command printed a result");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn payload_decode_prints_the_papers_offers() {
    assert_eq!(
        ok(&["payload", "decode", "011010"]),
        r#"{"site":"A","quality":2,"capacity":2,"withdrawn":false}"#
    );
    assert_eq!(
        ok(&["payload", "decode", "100111"]),
        r#"{"site":"B","quality":1,"capacity":3,"withdrawn":false}"#
    );
    assert_eq!(
        ok(&["payload", "decode", "010000"]),
        r#"{"site":"A","quality":0,"capacity":0,"withdrawn":true}"#
    );
}

#[test]
fn payload_decode_names_the_problem() {
    assert!(fails(&["payload", "decode", "01101"]).contains("6 bits"));
    assert!(fails(&["payload", "decode", "0110100"]).contains("6 bits"));
    assert!(fails(&["payload", "decode", "01x010"]).contains("not 0 or 1"));
    assert!(fails(&["payload", "decode", "001010"]).contains("site id 0"));
    assert!(fails(&["payload", "decode", "111010"]).contains("site id 3"));
}

/// `waggle payload encode` arguments.
fn encode<'a>(site: &'a str, quality: &'a str, capacity: &'a str) -> [&'a str; 8] {
    [
        "payload",
        "encode",
        "--site",
        site,
        "--quality",
        quality,
        "--capacity",
        capacity,
    ]
}

#[test]
fn payload_encode_round_trips_with_decode() {
    assert_eq!(ok(&encode("A", "2", "2")), "011010");
    assert_eq!(ok(&encode("B", "1", "3")), "100111");
    assert_eq!(ok(&encode("A", "0", "0")), "010000");
    assert!(fails(&encode("C", "1", "1")).contains("unknown site"));
    assert!(fails(&encode("A", "4", "1")).contains("quality 4"));
}

#[test]
fn allocate_reproduces_the_papers_allocations() {
    let run = |n: &str, offers: &str| ok(&["allocate", "--observers", n, "--offers", offers]);
    assert_eq!(run("3", "011010,100111"), r#"{"O1":"A","O2":"A","O3":"B"}"#);
    assert_eq!(run("3", "010000,100111"), r#"{"O1":"B","O2":"B","O3":"B"}"#);
    assert_eq!(
        run("3", "011001,100111"),
        r#"{"O1":"A","O2":"B","O3":"B"}"#,
        "O2-black round 2"
    );
    assert_eq!(run("1", "011001,100110"), r#"{"O1":"A"}"#);
    assert_eq!(run("2", "011001,100111"), r#"{"O1":"A","O2":"B"}"#);
    // Order of the offers on the command line does not matter.
    assert_eq!(run("3", "100111,011010"), r#"{"O1":"A","O2":"A","O3":"B"}"#);
    // Everything withdrawn: nobody is assigned.
    assert_eq!(run("2", "010000,100000"), r#"{"O1":null,"O2":null}"#);
}

#[test]
fn allocate_rejects_bad_input_with_a_reason() {
    let err = |n: &str, offers: &str| fails(&["allocate", "--observers", n, "--offers", offers]);
    assert!(err("3", "011010").contains("missing B"));
    assert!(err("3", "011010,010000").contains("two offers for site A"));
    assert!(err("3", "011010,1001").contains("6 bits"));
    assert!(err("0", "011010,100111").contains("between 1 and"));
    assert!(err("9", "011010,100111").contains("between 1 and"));
}
