//! `waggle._native`, the compiled half of the `waggle` Python package: Waggle's own receivers
//! (`perception`) and its event packets (`proto`) as Python objects, and the event streams of
//! its recordings (`recording`) as numpy arrays. This file only registers what each module
//! defines; the Python half (`python/waggle/`) re-exports it.
//!
//! The crate builds as a plain library too (no `extension-module` feature), so the workspace's
//! `cargo build`, `cargo test` and clippy link it like any other crate; maturin turns the
//! feature on for the wheel.

use pyo3::prelude::*;

pub mod camera;
pub mod errors;
pub mod events;
mod intact;
pub mod receivers;
pub mod recorded;
pub mod step;
mod wire_records;

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    events::register(m)?;
    step::register(m)?;
    receivers::register(m)?;
    recorded::register(m)?;
    Ok(())
}
