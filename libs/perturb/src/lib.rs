//! Perturbation models for seeded trials (`waggle trials`, `waggle study`): what a researcher
//! may perturb, each term a named parameter with its unit, all off by default.
//!
//! * `parameters` — the table of terms: key, unit, default (off), range, meaning.
//! * [`spec`] — the parameter set ([`Perturbation`]): `events.*` (the event sensor's v2e terms,
//!   applied by [`event_camera::NoisyConverter`]), `rgb.*` ([`rgb::RgbNoise`]), `geometry.*` and
//!   `flight.*` (placement jitter and gusts: a re-flown trial) and `link.*` ([`link::LinkNoise`]).
//! * [`flight`] — the flight terms' typed views: wind (`wind.*`: mean, direction, Dryden σ and
//!   length) and the cascade controller with its estimate (`flight.cascade`, `flight.estimate_*`).
//! * [`light`] — one illuminance (`light.lux`) from which both cameras' exposure, noise,
//!   blur, bandwidth and background activity follow.
//! * `check` — what terms mean together ([`Perturbation::check`]: the event sensor's shot noise
//!   with darkness's added stays within its own range).
//! * [`real`] — a real recording's background as the event sensor's noise, or the model
//!   fitted from it (`events.real_noise_*`).
//! * [`preset`] — named sensor presets (v2e's `clean`, default and `noisy` values), cited.
//! * [`reference`](mod@reference) — the user guide's page of every term and preset, rendered from the tables.
//! * [`seed`] — one trial seed → independent, reproducible streams per term and observer.
//! * [`stats`] — the Wilson score interval for success rates.
//!
//! Pure code: no I/O, no clock; the same seed gives the same realisation on every machine
//! (ChaCha8 streams, integer seeds).

pub mod attitude;
mod check;
pub mod error;
pub mod flight;
pub mod light;
pub mod link;
mod parameters;
pub mod preset;
pub mod real;
pub mod reference;
pub mod rgb;
pub mod seed;
pub mod spec;
pub mod stats;

pub use error::PerturbError;
pub use spec::Perturbation;
