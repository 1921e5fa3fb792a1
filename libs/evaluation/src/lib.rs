//! Evaluation-only code: what a run is measured against, never part of a running observer.
//!
//! - [`ideal_receiver`]: the ideal-message baseline, which projects ground-truth performer
//!   positions into every observer's camera and decodes them with the same segmenter and parser
//!   as the real receivers. It lives here, in a crate no observer process links (the isolation
//!   test in `observer-node` checks the manifests), because it knows the truth.

pub mod ideal_receiver;

pub use ideal_receiver::{IdealReceiver, IdealReceiverError, ObserverOutput};
