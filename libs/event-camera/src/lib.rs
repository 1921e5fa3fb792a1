//! Synthetic event camera: an exact threshold-crossing converter and a 40 ms packetiser.
//!
//! Pure code (no I/O but a calibration file read on request): the camera process feeds
//! rendered RGB frames and publishes the packets; `waggle events convert` feeds PNG frames from
//! disk. A real camera's recorded or live events are moved into the receivers' reference camera
//! by [`calibration`] and cut into the same packets by [`packets`].
//!
//! # The model (docs/DESIGN.md §7, the paper's "Synthetic event generation")
//!
//! * Log luminance `L = ln(max(0.299R + 0.587G + 0.114B, 1))`, defined bit-exactly in
//!   [`luminance`]: `Y = (299R + 587G + 114B) / 1000` formed as an exact integer, divided once in
//!   f64, then f64 `ln`.
//! * Each pixel keeps `L_init` (its first frame) and an integer level `n`; its reference is
//!   `L_init + n·C`, never an accumulated float. With `d = L − L_init` (one f64 subtraction):
//!   up-events fire while `d ≥ (n+1)·C` (each sets `n += 1`), down-events while `d ≤ (n−1)·C`
//!   (each sets `n −= 1`); `(n±1)·C` is `f64::from(n ± 1) * C`. Inclusive comparisons make a
//!   pixel that returns exactly to a former value return to the same level.
//! * Crossing of level `k` inside the interval `(t0, t1]`: with `d0`, `d1` the values of `d` at
//!   the two frames, `frac = (f64::from(k)·C − d0) / (d1 − d0)` and
//!   `t = t0 + clamp(ceil(frac · (t1 − t0) as f64), 1, t1 − t0)` integer nanoseconds. Rounding up
//!   keeps every event strictly after the earlier frame, matching the packets' (start, end]
//!   watermarks.
//! * The first frame only initialises. Events of one interval are sorted by time, then pixel
//!   index `y·width + x`, then crossing order.
//!
//! [`reference::ReferenceConverter`] states this literally; [`Converter`] is the fast,
//! bit-identical implementation used everywhere else. [`EventCamera`] cuts the stream into
//! [`proto::EventPacket`]s; [`picture`] draws packets the way the paper's figure does.
//!
//! # Sensor noise (off by default)
//!
//! [`EventNoise`] adds the non-idealities of the v2e model (Hu, Liu, Delbruck 2021), checked
//! against v2e's own output (`tests/v2e.rs`; see [`noise`] for the exact rules), all seeded by
//! one `seed`:
//!
//! * `linlog_dn` (luminance): v2e's lin-log curve, linear below the knee;
//! * `cutoff_hz` (Hz): intensity-dependent photoreceptor low-pass;
//! * `threshold_sigma` (log intensity): per-pixel threshold mismatch `C_i ~ N(C, σ²)`, clamped
//!   to ≥ [`noise::MIN_PIXEL_THRESHOLD`];
//! * `refractory_ns` (ns): crossings within this time after a pixel's last emitted event are
//!   not emitted (its level still follows the input);
//! * `leak_hz` (Hz), `leak_spread_decades`, `leak_jitter`: the reference leaks down by
//!   `leak_hz·C_i` per second, at a rate that varies across pixels and over time;
//! * `shot_noise_hz` (Hz per pixel), `shot_noise_bright_drop`: Poisson spurious events, fair
//!   polarity, no effect on the reference, more in low-threshold and dark pixels;
//! * `hot_pixels`, `hot_pixel_hz` (count, Hz): distinct pixels emitting periodic ON events.
//!
//! [`NoisyConverter`] implements it with the [`Converter`] API and is bit-identical to it when
//! the noise is ideal ([`EventNoise::is_ideal`]). [`CameraConfig::noise`] defaults to the ideal
//! sensor, for which [`EventCamera`] keeps using the exact [`Converter`].

pub mod calibration;
pub mod camera;
pub mod converter;
pub mod error;
pub mod event;
pub mod fit;
mod kernel;
pub mod luminance;
pub mod noise;
pub mod packets;
pub mod picture;
mod prefetch;
pub mod real_noise;
pub mod reference;
pub mod synthetic;

pub use camera::{CameraConfig, EventCamera, EventSensorModel};
pub use converter::Converter;
pub use error::{CameraError, ConvertError, MIN_THRESHOLD, NoiseError, PictureError};
pub use event::{DEFAULT_THRESHOLD, Event, Polarity};
pub use noise::{EventNoise, MAX_NOISE_RATE_HZ, NoisyConverter};
