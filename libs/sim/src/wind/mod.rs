//! Wind: a mean wind plus seeded Dryden turbulence ([`dryden`]), and the aerodynamic drag it
//! exerts on a Crazyflie ([`RotorDrag`]).
//!
//! **Field.** Spatially uniform (one velocity for the whole scene at each instant, like MuJoCo's
//! global `opt.wind`), horizontal mean `mean_mps` blowing *towards* `direction_rad` (anticlockwise
//! from world +x), turbulence in the axes u (along that direction), v (across it, to its left)
//! and w (up). It acts on every drone, observers included. Advanced once per physics step.
//!
//! **Drag — why not MuJoCo's fluid model.** MuJoCo's passive fluid forces (`opt.density`,
//! `opt.viscosity`, `opt.wind`; inertia-box or `fluidshape="ellipsoid"` geoms) are body drag,
//! quadratic in airspeed, plus Stokes viscous drag, which at air's viscosity is negligible. A
//! small quadrotor's drag at the airspeeds of this study (0–3 m/s) is dominated by *rotor* drag
//! (blade flapping and induced drag), which is linear in the relative airspeed and proportional
//! to the rotors' speed (Förster 2015, below). A quadratic model calibrated at 2 m/s would be
//! 4× too weak at 0.5 m/s, where hover turbulence lives. So the drag is applied explicitly at the
//! centre of mass (in `xfrc_applied`, with the controller's wrench) as the linear rotor-drag
//! model, and MuJoCo's `opt.density`/`opt.viscosity` stay 0 (MuJoCo then computes no fluid force
//! at all, so the windless scene is untouched).
//!
//! **Calibration.** Förster, *System Identification of the Crazyflie 2.0 Nano Quadrocopter*
//! (BSc thesis, ETH Zürich, 2015) identifies `F_body = K·(Σ ωᵢ)·v_body`, K diagonal; the
//! values used here are those of gym-pybullet-drones' `cf2x.urdf` (Panerati et al., IROS 2021),
//! which take them from Förster: `drag_coeff_xy = 9.1785e-7`, `drag_coeff_z = 10.311e-7`
//! kg/rad, with `kf = 3.16e-10` N/rpm² and mass 0.027 kg. At hover Σω = 4·√(mg/(4kf))·2π/60 =
//! 6064 rad/s, so `k_xy` = 5.566 mN/(m/s) and `k_z` = 6.253 mN/(m/s): **a hovering Crazyflie in a
//! 2 m/s horizontal wind feels 11.1 mN** (4.2 % of its weight). Uncertainty, stated plainly: we
//! could not check the thesis table itself here; the xy/z assignment in cf2x.urdf is taken as
//! published. The coefficients are held at their hover value (the rotor speed changes ≈ ±10 %
//! with thrust in these flights).

pub mod dryden;

use crate::control::rotate;
use crate::mjcf::DRONE_MASS_KG;
use dryden::{Dryden, DrydenError, DrydenParams};

/// Linear rotor drag, body frame: `F_body = −diag(k_xy, k_xy, k_z)·(v − v_wind)_body`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RotorDrag {
    /// Horizontal (body x, y) coefficient, N/(m/s).
    pub k_xy_nspm: f64,
    /// Vertical (body z) coefficient, N/(m/s).
    pub k_z_nspm: f64,
}

/// gym-pybullet-drones `cf2x.urdf` (from Förster 2015): drag per rad/s of summed rotor speed.
pub const CF2X_DRAG_COEFF_XY: f64 = 9.1785e-7;
/// As [`CF2X_DRAG_COEFF_XY`], body z.
pub const CF2X_DRAG_COEFF_Z: f64 = 10.311e-7;
/// gym-pybullet-drones `cf2x.urdf` thrust coefficient, N/rpm².
pub const CF2X_KF_N_PER_RPM2: f64 = 3.16e-10;
/// Gravity of the scene, m/s² (`mjcf`'s `<option gravity>`).
const GRAVITY_MPS2: f64 = 9.81;

impl RotorDrag {
    /// The Crazyflie at hover (module doc): k_xy = 5.566e-3, k_z = 6.253e-3 N/(m/s).
    pub fn crazyflie() -> Self {
        let rpm = (DRONE_MASS_KG * GRAVITY_MPS2 / (4.0 * CF2X_KF_N_PER_RPM2)).sqrt();
        let sum_omega_radps = 4.0 * rpm * std::f64::consts::TAU / 60.0;
        Self {
            k_xy_nspm: CF2X_DRAG_COEFF_XY * sum_omega_radps,
            k_z_nspm: CF2X_DRAG_COEFF_Z * sum_omega_radps,
        }
    }

    /// Drag force, world frame, N, on a drone with attitude `world_from_body` moving at `vel_mps`
    /// through air moving at `wind_mps` (both world frame).
    pub fn force_n(
        &self,
        world_from_body: [f64; 4],
        vel_mps: [f64; 3],
        wind_mps: [f64; 3],
    ) -> [f64; 3] {
        let rel = [
            vel_mps[0] - wind_mps[0],
            vel_mps[1] - wind_mps[1],
            vel_mps[2] - wind_mps[2],
        ];
        let [w, x, y, z] = world_from_body;
        let rel_body = rotate([w, -x, -y, -z], rel);
        let f_body = [
            -self.k_xy_nspm * rel_body[0],
            -self.k_xy_nspm * rel_body[1],
            -self.k_z_nspm * rel_body[2],
        ];
        rotate(world_from_body, f_body)
    }
}

/// A wind: mean, turbulence and the drag it exerts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindConfig {
    /// Mean horizontal wind speed, m/s.
    pub mean_mps: f64,
    /// Direction the mean wind blows towards, rad, anticlockwise from world +x.
    pub direction_rad: f64,
    /// Dryden turbulence, `None` for a steady wind.
    pub turbulence: Option<DrydenParams>,
    /// Seed of the turbulence (a `perturb::seed` stream).
    pub seed: u64,
    pub drag: RotorDrag,
}

impl WindConfig {
    /// The perturbation terms' wind: mean `mean_mps` towards `direction_deg`, horizontal
    /// turbulence σ `sigma_mps` (0: none) in the low-altitude form, `length_m` (0: the form's
    /// own at 10 ft, 23 m) as `L_u = L_v`, Crazyflie rotor drag.
    pub fn from_terms(
        mean_mps: f64,
        direction_deg: f64,
        sigma_mps: f64,
        length_m: f64,
        seed: u64,
    ) -> Self {
        let length = (length_m > 0.0).then_some(length_m);
        Self {
            mean_mps,
            direction_rad: direction_deg.to_radians(),
            turbulence: (sigma_mps > 0.0)
                .then(|| DrydenParams::low_altitude(sigma_mps, length, mean_mps)),
            seed,
            drag: RotorDrag::crazyflie(),
        }
    }
}

/// Why a wind could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WindError {
    #[error(transparent)]
    Dryden(#[from] DrydenError),
    #[error("mean wind {0} m/s must be finite and ≥ 0")]
    Mean(f64),
}

/// The wind over the scene, advanced once per physics step.
#[derive(Debug, Clone)]
pub struct WindField {
    config: WindConfig,
    turbulence: Option<Dryden>,
    velocity_mps: [f64; 3],
}

impl WindField {
    /// The wind of `config`, sampled every `step_ns`; its first sample is the wind at time 0.
    pub fn new(config: WindConfig, step_ns: u64) -> Result<Self, WindError> {
        if !(config.mean_mps.is_finite() && config.mean_mps >= 0.0) {
            return Err(WindError::Mean(config.mean_mps));
        }
        let turbulence = config
            .turbulence
            .map(|p| Dryden::new(p, step_ns, config.seed))
            .transpose()?;
        let mut field = Self {
            config,
            turbulence,
            velocity_mps: [0.0; 3],
        };
        field.velocity_mps = field.compose();
        Ok(field)
    }

    /// The configuration.
    pub fn config(&self) -> &WindConfig {
        &self.config
    }

    /// The wind velocity now, world frame, m/s.
    pub fn velocity_mps(&self) -> [f64; 3] {
        self.velocity_mps
    }

    /// Advances one step; returns the new wind velocity, world frame, m/s.
    pub fn advance(&mut self) -> [f64; 3] {
        if let Some(t) = self.turbulence.as_mut() {
            t.advance();
        }
        self.velocity_mps = self.compose();
        self.velocity_mps
    }

    /// The drag on a drone (world frame, N) at attitude `world_from_body` and velocity `vel_mps`.
    pub fn drag_n(&self, world_from_body: [f64; 4], vel_mps: [f64; 3]) -> [f64; 3] {
        self.config
            .drag
            .force_n(world_from_body, vel_mps, self.velocity_mps)
    }

    fn compose(&self) -> [f64; 3] {
        let [u, v, w] = self.turbulence.as_ref().map_or([0.0; 3], Dryden::gust_mps);
        let (s, c) = self.config.direction_rad.sin_cos();
        let along = self.config.mean_mps + u;
        [along * c - v * s, along * s + v * c, w]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crazyflie_drag_at_two_metres_per_second() {
        let d = RotorDrag::crazyflie();
        assert!((d.k_xy_nspm - 5.566e-3).abs() < 5e-6, "{d:?}");
        assert!((d.k_z_nspm - 6.253e-3).abs() < 5e-6, "{d:?}");
        let f = d.force_n([1.0, 0.0, 0.0, 0.0], [0.0; 3], [2.0, 0.0, 0.0]);
        assert!(
            (f[0] - 0.01113).abs() < 2e-5 && f[1] == 0.0 && f[2] == 0.0,
            "{f:?}"
        );
        // Yawed 90°: same world force (xy symmetric).
        let h = std::f64::consts::FRAC_PI_4;
        let g = d.force_n([h.cos(), 0.0, 0.0, h.sin()], [0.0; 3], [2.0, 0.0, 0.0]);
        assert!((g[0] - f[0]).abs() < 1e-12 && g[1].abs() < 1e-12, "{g:?}");
    }

    #[test]
    fn steady_wind_blows_towards_its_direction() {
        let cfg = WindConfig::from_terms(2.0, 90.0, 0.0, 0.0, 1);
        let mut w = WindField::new(cfg, 2_000_000).unwrap();
        let v = w.advance();
        assert!(v[0].abs() < 1e-12 && (v[1] - 2.0).abs() < 1e-12 && v[2] == 0.0);
    }
}
