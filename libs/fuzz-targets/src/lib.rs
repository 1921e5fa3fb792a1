//! Fuzz targets: one function per parser of bytes that come from outside a Waggle process —
//! bus messages, event-camera files, recordings, ROS 2 bags and messages, calibration and case
//! files, link study files, compose files, a receiver plug-in's replies, an institution's CA
//! certificate and key, the lab's per-trial records and render cache entries. Each takes the fuzzer's bytes, hands them to the real
//! parser and checks what it can beyond "no panic": a decoded value re-encodes to the same bytes
//! or decodes again to the same value, and a refusal is an error, never a panic or an allocation
//! sized by a length field.
//!
//! The `fuzz/` crate at the repository root calls these functions from libFuzzer (one binary
//! per target), and `tests/corpora.rs` replays every corpus and regression file through them
//! as an ordinary test. [`TARGETS`] names them all; [`seeds`] makes the seed corpora with
//! Waggle's own writers.

pub mod events;
pub mod recorded;
pub mod ros2;
pub mod runs;
pub mod seeds;
pub mod text;
pub mod tls;
pub mod wire;

pub use events::{aedat4, dat, event_writers, evt2, evt3};
pub use recorded::recording;
pub use ros2::{ros2_bag, ros2_cdr};
pub use runs::{render_cache, trial_record};
pub use text::{calibration, case_toml, compose_toml, plugin_reply, study_toml};
pub use tls::tls_pem;
pub use wire::{wire_key, wire_message};

/// A fuzz target: the fuzzer's bytes in, a panic on a broken invariant.
pub type FuzzTarget = fn(&[u8]);

/// Every target by name: the name of its `fuzz/fuzz_targets/NAME.rs` binary and of its corpus
/// directory `fuzz/corpus/NAME/` (and `fuzz/regressions/NAME/`).
pub const TARGETS: &[(&str, FuzzTarget)] = &[
    ("wire_message", wire_message),
    ("wire_key", wire_key),
    ("evt3", evt3),
    ("evt2", evt2),
    ("dat", dat),
    ("aedat4", aedat4),
    ("event_writers", event_writers),
    ("recording", recording),
    ("ros2_cdr", ros2_cdr),
    ("ros2_bag", ros2_bag),
    ("calibration", calibration),
    ("case_toml", case_toml),
    ("study_toml", study_toml),
    ("plugin_reply", plugin_reply),
    ("tls_pem", tls_pem),
    ("trial_record", trial_record),
    ("compose_toml", compose_toml),
    ("render_cache", render_cache),
];
