//! The real-noise source of a perturbation: a recording's background laid over the event
//! sensor ([`event_camera::real_noise`]), or, with `events.real_noise_fitted = 1`, the model's
//! terms fitted from that same background, so a study can set a real sensor's noise against
//! the model of it.
//!
//! Both are scaled by `events.real_noise_copies`: copies of the recording overlaid, or the
//! fitted rates and hot-pixel density times the copies.

use std::sync::Arc;

use event_camera::EventNoise;
use event_camera::real_noise::{RealNoise, RealNoiseTiler};
use proto::scene::{IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX};

use crate::error::PerturbError;
use crate::spec::{Perturbation, parameter};

/// Salt of the replay's offsets, so they are independent of the sensor's own noise draws.
const TILER_SALT: u64 = 0x7265_616C_6E6F_6973;

impl Perturbation {
    /// This perturbation with `source` as its real-noise source.
    pub fn with_real_noise(mut self, source: Arc<RealNoise>) -> Self {
        self.real_noise = Some(source);
        self
    }

    /// The real-noise source, if any.
    pub fn real_noise(&self) -> Option<&Arc<RealNoise>> {
        self.real_noise.as_ref()
    }

    /// `events.real_noise_copies`.
    pub fn real_noise_copies(&self) -> u32 {
        self.get("events.real_noise_copies") as u32
    }

    /// `events.real_noise_fitted = 1`: the fitted model instead of the recording's events.
    pub fn real_noise_fitted(&self) -> bool {
        self.get("events.real_noise_fitted") != 0.0
    }

    /// The replay of the source's events into a `width`×`height` sensor seeded with the
    /// sensor's `seed` (None without a source, or when the fitted model stands in for it).
    pub fn real_noise_tiler(&self, width: u16, height: u16, seed: u64) -> Option<RealNoiseTiler> {
        let source = self
            .real_noise
            .as_ref()
            .filter(|_| !self.real_noise_fitted())?;
        Some(RealNoiseTiler::new(
            source.clone(),
            self.real_noise_copies(),
            width,
            height,
            seed ^ TILER_SALT,
        ))
    }

    /// Adds the fitted source's terms to `noise` when `events.real_noise_fitted = 1`.
    pub(crate) fn add_fitted_real_noise(&self, noise: &mut EventNoise) {
        let Some(source) = self
            .real_noise
            .as_ref()
            .filter(|_| self.real_noise_fitted())
        else {
            return;
        };
        let (copies, fit) = (f64::from(self.real_noise_copies()), &source.fitted);
        noise.shot_noise_hz += copies * fit.shot_noise_hz;
        noise.leak_hz += copies * fit.leak_hz;
        let density = fit.hot_pixels.len() as f64
            / (f64::from(source.width) * f64::from(source.height)).max(1.0);
        let sensor_px = f64::from(IMAGE_WIDTH_PX) * f64::from(IMAGE_HEIGHT_PX);
        let hot = (copies * density * sensor_px).round() as u32;
        if hot > 0 {
            if noise.hot_pixels == 0 {
                noise.hot_pixel_hz = fit.hot_pixel_hz;
            }
            noise.hot_pixels += hot;
        }
    }

    /// Refuses real-noise terms without a source, and a fitted model past the terms' ranges.
    pub fn check_real_noise(&self) -> Result<(), PerturbError> {
        if self.real_noise.is_none() {
            for key in ["events.real_noise_copies", "events.real_noise_fitted"] {
                if self.non_default().contains_key(key) {
                    return Err(PerturbError::RealNoiseWithoutSource(key));
                }
            }
            return Ok(());
        }
        let noise = self.event_noise(0);
        for (key, value) in [
            ("events.shot_noise_hz", noise.shot_noise_hz),
            ("events.leak_hz", noise.leak_hz),
            ("events.hot_pixels", f64::from(noise.hot_pixels)),
        ] {
            let max = parameter(key).map_or(f64::INFINITY, |p| p.max);
            if value > max {
                return Err(PerturbError::RealNoiseFitTooLoud {
                    key,
                    value,
                    copies: self.real_noise_copies(),
                    max,
                });
            }
        }
        Ok(())
    }
}
