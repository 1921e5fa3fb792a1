//! MuJoCo physics, scene generation and headless rendering for Waggle.
//!
//! - [`mjcf`] generates the scene for N observers from the shared geometry in [`proto::scene`].
//! - [`world`] steps physics at 500 Hz on an integer-nanosecond clock with ideal world-frame
//!   force/torque stabilisation ([`control`]) and counts drone–drone contact steps.
//! - [`render`] renders observer cameras headlessly (EGL; Mesa's CPU rasteriser here).
//!
//! The MuJoCo FFI and its `unsafe` live in the `mujoco-rs` crate; this crate has none.

#![forbid(unsafe_code)]

pub mod assets;
pub mod control;
pub mod damage;
pub mod mjcf;
pub mod render;
pub mod sensor;
pub mod world;
