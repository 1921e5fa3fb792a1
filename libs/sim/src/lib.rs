//! MuJoCo physics, scene generation and headless rendering for Waggle.
//!
//! - [`mjcf`] generates the scene for N observers from the shared geometry in [`proto::scene`].
//! - [`world`] steps physics at 500 Hz on an integer-nanosecond clock with ideal world-frame
//!   force/torque stabilisation ([`control`]) or, as an option, a Crazyflie-like cascade
//!   ([`cascade`], seeing the state through [`estimate`]), an optional wind ([`wind`]: mean plus
//!   seeded Dryden turbulence, Crazyflie rotor drag), counts drone–drone contact steps and
//!   keeps each drone's tracking error.
//! - [`noise`] is the seeded Gaussian source of those random processes.
//! - [`render`] renders observer cameras headlessly: by the Rust renderer ([`raster`], fed by
//!   [`raster_view`]) or, as the reference, by MuJoCo's renderer in EGL (Mesa's CPU rasteriser).
//! - [`lockstep`] is the simulator's side of the lockstep (published truth, a camera's mirror
//!   of it, one tick's extrapolated references), shared by `sim-node` and `waggle mission`.
//!
//! The MuJoCo FFI and its `unsafe` live in the `mujoco-rs` crate; this crate has none.

#![forbid(unsafe_code)]

pub mod assets;
pub mod cascade;
pub mod control;
pub mod damage;
pub mod estimate;
pub mod lockstep;
pub mod mjcf;
pub mod noise;
pub mod raster_view;
pub mod render;
pub mod sensor;
mod vec3;
pub mod wind;
pub mod world;
