//! One light level for both sensors: the scene illuminance `light.lux` and what each camera
//! makes of it. With `light.lux = 0` (the default) light is not modelled and both sensors are
//! exactly as their own terms say.
//!
//! # RGB camera (a small global-shutter CMOS module, values assumed and listed below)
//!
//! * Sensor-plane illuminance of a Lambertian surface of reflectance ρ under illuminance E, by
//!   the camera equation: `E_s = E·ρ·T / (4·N²)` (lens transmission T, f-number N).
//! * Photons: 1 lx is 1/683 W/m² at 555 nm, i.e. `4.09e15` photons/(s·m²) (the definition of the
//!   lumen); broadband light gives more photons per lux, so this is the conservative end.
//! * Electrons per second of a white pixel: `E_s · 4.09e15 · pitch² · QE`; a rendered value v
//!   (0–255) is treated as reflectance `ρ_white·v/255` (renders are not photometric: the
//!   paper's own limitation).
//! * Auto-exposure: the exposure that fills `AE_TARGET` of the full well at white, at most one
//!   RGB frame (40 ms); then a gain that maps the white level to 255, at most `MAX_GAIN` × the
//!   gain that maps `AE_TARGET` of the full well to 255. Past both limits the image darkens.
//! * Each value is `gain · (Poisson(electrons) + N(0, read noise))`, rounded and clamped: photon
//!   shot noise and read noise in electrons (EMVA 1288's linear camera model).
//! * Motion blur: the frame integrates the exposure, as the mean of `round(exposure / 10 ms)`
//!   renders (1–4; Waggle renders every 10 ms, so blur is quantised to that).
//!
//! # Event camera (background measured, bandwidth assumed)
//!
//! * Photoreceptor bandwidth is proportional to photocurrent (Delbruck & Mead's adaptive
//!   photoreceptor; v2e scales its cutoff with intensity for the same reason): the cutoff at
//!   white is `events.cutoff_hz · light.cutoff_scale · E / LUX_REF`, with v2e's default 300 Hz
//!   when no cutoff is given, placed at office light (`LUX_REF` = 500 lx). Where v2e's cutoff
//!   sits in lux is an assumption no reachable measurement fixes; `light.cutoff_scale` moves it
//!   (0.3 and 3 bracket it in the light study).
//! * Background activity grows as light falls (Graça & Delbruck, "Unraveling the paradox of
//!   intensity-dependent DVS pixel noise", IISW 2021): shot noise `events.shot_noise_hz +
//!   light.dim_shot_hz_lx / E`. The default constant is measured: IEBCS's per-pixel noise
//!   distributions of a real sensor give 4.24 OFF events/s per pixel at 0.1 lx, and fair shot
//!   noise is twice its OFF rate, so [`MEASURED_DIM_SHOT_HZ_LX`] = 2 · 4.24 Hz · 0.1 lx
//!   (`tools/iebcs/iebcs_background.py` derives it). [`ASSUMED_DIM_SHOT_HZ_LX`], the earlier
//!   assumption of ≈ 10 Hz per pixel at 1 lx, stays selectable.
//!
//! Every mapping is monotonic in E (tested): less light never gives a shorter exposure, less
//! noise, a wider bandwidth or fewer background events.

/// Office light, lx: where v2e's default cutoff is placed.
pub const LUX_REF: f64 = 500.0;
/// Shot noise darkness adds, Hz per pixel times lx (∝ 1/E), measured: twice the 4.243 OFF
/// events/s per pixel of IEBCS's real sensor at 0.1 lx (its 161 lx and 3 000 lx distributions,
/// 0.0012 and 0 OFF events/s per pixel, agree with 1/E within their few events).
pub const MEASURED_DIM_SHOT_HZ_LX: f64 = 0.8486;
/// The earlier assumption: ≈ 10 Hz per pixel at 1 lx (`light.dim_shot_hz_lx = 10`).
pub const ASSUMED_DIM_SHOT_HZ_LX: f64 = 10.0;
/// v2e's default photoreceptor cutoff, used at `LUX_REF` when the sensor names none.
pub const DEFAULT_CUTOFF_HZ: f64 = 300.0;
/// Largest cutoff the light model gives, Hz (the term's own limit).
pub const MAX_CUTOFF_HZ: f64 = 10_000.0;

/// Photons per second per m² in 1 lx at 555 nm.
const PHOTONS_PER_LUX: f64 = 4.09e15;

/// The RGB camera the light model assumes (values typical of small global-shutter CMOS
/// modules on drones; change them here, they are not tuned to any result).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RgbCamera {
    pub pixel_pitch_um: f64,
    pub quantum_efficiency: f64,
    pub full_well_e: f64,
    pub read_noise_e: f64,
    pub f_number: f64,
    pub lens_transmission: f64,
    /// Reflectance of what renders as white (255).
    pub white_reflectance: f64,
    /// Longest exposure: one RGB frame, ms.
    pub max_exposure_ms: f64,
    /// Fraction of the full well auto-exposure aims white at.
    pub ae_target: f64,
    /// Highest gain, relative to the gain that maps `ae_target` of the full well to 255.
    pub max_gain: f64,
}

/// The assumed camera.
pub const RGB_CAMERA: RgbCamera = RgbCamera {
    pixel_pitch_um: 3.0,
    quantum_efficiency: 0.6,
    full_well_e: 10_000.0,
    read_noise_e: 3.0,
    f_number: 2.0,
    lens_transmission: 0.9,
    white_reflectance: 0.9,
    max_exposure_ms: 40.0,
    ae_target: 0.8,
    max_gain: 16.0,
};

/// What auto-exposure chose at one light level.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Exposure {
    pub exposure_ms: f64,
    /// Grey levels per electron.
    pub gain_grey_per_e: f64,
    /// Electrons a white pixel collects.
    pub white_e: f64,
}

impl RgbCamera {
    /// Electrons per second a white pixel collects under `lux`.
    pub fn white_e_per_s(&self, lux: f64) -> f64 {
        let sensor_lux = lux * self.white_reflectance * self.lens_transmission
            / (4.0 * self.f_number * self.f_number);
        let area_m2 = (self.pixel_pitch_um * 1e-6).powi(2);
        sensor_lux * PHOTONS_PER_LUX * area_m2 * self.quantum_efficiency
    }

    /// Auto-exposure at `lux` (> 0).
    pub fn exposure(&self, lux: f64) -> Exposure {
        let rate = self.white_e_per_s(lux);
        let target_e = self.ae_target * self.full_well_e;
        let exposure_ms = (target_e / rate * 1e3).min(self.max_exposure_ms);
        let white_e = rate * exposure_ms * 1e-3;
        let unity = 255.0 / target_e;
        let gain_grey_per_e = (255.0 / white_e).min(self.max_gain * unity);
        Exposure {
            exposure_ms,
            gain_grey_per_e,
            white_e,
        }
    }

    /// Renders (10 ms each) averaged into one frame at `lux`: the exposure, quantised.
    pub fn blur_renders(&self, lux: f64) -> u32 {
        ((self.exposure(lux).exposure_ms / 10.0).round() as u32).clamp(1, 4)
    }
}

/// The event sensor's cutoff at white under `lux`, from its cutoff at `LUX_REF` (`at_ref_hz`,
/// 0: v2e's default) times `scale` (`light.cutoff_scale`).
pub fn event_cutoff_hz(lux: f64, at_ref_hz: f64, scale: f64) -> f64 {
    let at_ref = if at_ref_hz > 0.0 {
        at_ref_hz
    } else {
        DEFAULT_CUTOFF_HZ
    };
    (at_ref * scale * lux / LUX_REF).min(MAX_CUTOFF_HZ)
}

/// The event sensor's shot noise under `lux`: the sensor's own plus darkness's
/// (`dim_hz_lx / lux`).
pub fn event_shot_noise_hz(lux: f64, own_hz: f64, dim_hz_lx: f64) -> f64 {
    own_hz + dim_hz_lx / lux
}

#[cfg(test)]
mod tests {
    use super::*;

    const LEVELS: [f64; 9] = [2000.0, 500.0, 200.0, 100.0, 50.0, 20.0, 10.0, 5.0, 1.0];

    #[test]
    fn every_mapping_is_monotonic_in_the_light() {
        for w in LEVELS.windows(2) {
            let (bright, dim) = (w[0], w[1]);
            let (a, b) = (RGB_CAMERA.exposure(bright), RGB_CAMERA.exposure(dim));
            assert!(b.exposure_ms >= a.exposure_ms, "{bright} → {dim}");
            assert!(b.white_e <= a.white_e, "{bright} → {dim}");
            assert!(b.gain_grey_per_e >= a.gain_grey_per_e, "{bright} → {dim}");
            assert!(RGB_CAMERA.blur_renders(dim) >= RGB_CAMERA.blur_renders(bright));
            for scale in [0.3, 1.0, 3.0] {
                assert!(event_cutoff_hz(dim, 0.0, scale) < event_cutoff_hz(bright, 0.0, scale));
            }
            for dim_hz_lx in [MEASURED_DIM_SHOT_HZ_LX, ASSUMED_DIM_SHOT_HZ_LX] {
                let shot = |lux| event_shot_noise_hz(lux, 0.001, dim_hz_lx);
                assert!(shot(dim) > shot(bright));
            }
        }
    }

    #[test]
    fn office_light_is_a_short_exposure_and_dusk_runs_out_of_light() {
        let office = RGB_CAMERA.exposure(500.0);
        // ≈ 1 100 e⁻/s per lx at white: 8 000 e⁻ in ≈ 14 ms.
        assert!((RGB_CAMERA.white_e_per_s(1.0) - 1118.0).abs() < 5.0);
        assert!((office.exposure_ms - 14.3).abs() < 0.2, "{office:?}");
        assert!((office.gain_grey_per_e * office.white_e - 255.0).abs() < 1e-9);
        let dusk = RGB_CAMERA.exposure(5.0);
        assert_eq!(dusk.exposure_ms, 40.0);
        assert!(dusk.white_e < 300.0, "{dusk:?}");
        assert_eq!(event_cutoff_hz(LUX_REF, 0.0, 1.0), 300.0);
        assert_eq!(event_cutoff_hz(50.0, 30.0, 1.0), 3.0);
        assert!((event_cutoff_hz(50.0, 30.0, 3.0) - 9.0).abs() < 1e-12);
        assert!((event_shot_noise_hz(1.0, 0.0, ASSUMED_DIM_SHOT_HZ_LX) - 10.0).abs() < 1e-12);
        // IEBCS's sensor at 0.1 lx: 4.243 OFF events/s per pixel, half the shot noise.
        let at_tenth = event_shot_noise_hz(0.1, 0.0, MEASURED_DIM_SHOT_HZ_LX);
        assert!((at_tenth / 2.0 - 4.243).abs() < 0.001, "{at_tenth}");
    }
}
