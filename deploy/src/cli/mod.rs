//! The adapters of the `waggle` commands that this binary runs: each takes its arguments as
//! parsed by the `commands` crate (the one definition of the command line), calls the library
//! and prints the result. The lab commands go to the `waggle-lab` binary ([`lab`]).

pub mod allocate;
pub mod audit;
pub mod bench;
pub mod bundle;
pub mod compose;
pub mod export;
pub mod lab;
pub mod payload;
pub mod replay;
pub mod router;
pub mod run;
pub mod up;
