//! Receivers written by researchers, in Python, run by Waggle's instrument as its own receivers
//! are: same sensor input, same decoding below the level the plug-in replaces, scored by the same
//! criterion.
//!
//! A plug-in (`python:MODULE:CLASS`, [`PluginSpec`]) runs in a worker process
//! (`python -m waggle._worker`), one per job, so no interpreter lock serialises jobs and a hung
//! plug-in can be killed. The worker speaks framed messages over its stdin and stdout
//! ([`wire`], sans I/O); [`worker`] spawns it and waits for each reply until the trial's
//! deadline; [`receiver`] is one observer's receiver on a worker at the plug-in's level:
//! a tracker (its image positions go through Waggle's segmenter and frame parser), a token
//! receiver (its tokens go through Waggle's frame parser) or a full receiver (frames);
//! [`chain`] is a plug-in as an observer's whole receiving chain in a mission.

pub mod chain;
pub mod error;
pub mod receiver;
pub mod spec;
pub mod wire;
pub mod worker;

pub use chain::{ObserverPlugin, PluginChain};
pub use error::PluginError;
pub use receiver::{Level, ObserverInfo, PluginCounts, PluginReceiver, Pushed};
pub use spec::PluginSpec;
pub use worker::{Worker, WorkerPool};
