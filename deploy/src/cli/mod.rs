//! The `waggle` command line: one small adapter per command, each parsing its arguments
//! (clap), calling the library and printing the result. `src/main.rs` only dispatches.

pub mod allocate;
pub mod audit;
pub mod bench;
pub mod events;
pub mod link;
pub mod mission;
pub mod payload;
pub mod replay;
pub mod report;
pub mod run;
pub mod sweep;
