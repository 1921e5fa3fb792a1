//! The lab commands of `waggle` (served by `waggle-lab`): one small adapter per command, each
//! parsing its arguments (clap), calling the library and printing the result. The argument
//! groups they share with the operations are `deploy`'s.

pub mod decode;
pub mod events;
pub mod inputs;
pub mod link;
pub mod mission;
pub mod observe;
pub mod report;
pub mod sensor_fit;
pub mod shard;
pub mod study;
pub mod sweep;
pub mod trials;
pub mod viewpoints;

pub use commands::common::{CaseOverrides, PerturbArgs, RenderArg, parse_jobs};
