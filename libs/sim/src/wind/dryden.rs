//! The Dryden turbulence model (MIL-F-8785C §3.7.3; MIL-HDBK-1797 low-altitude form) as a seeded
//! process sampled exactly on a fixed integer-nanosecond step.
//!
//! **Spectra** (one-sided, per rad/s of temporal frequency ω, airspeed/advection speed V):
//!
//! ```text
//! Φ_u(ω) = σ_u² · 2L_u/(πV) · 1 / (1 + (L_u ω/V)²)
//! Φ_v(ω) = σ_v² ·  L_v/(πV) · (1 + 3(L_v ω/V)²) / (1 + (L_v ω/V)²)²      (Φ_w likewise, L_w, σ_w)
//! ```
//!
//! equivalently the autocorrelations `R_u(τ) = σ_u² e^{−Vτ/L_u}` and
//! `R_v(τ) = σ_v² (1 − Vτ/(2L_v)) e^{−Vτ/L_v}` ([`autocorrelation_longitudinal`],
//! [`autocorrelation_lateral`], [`psd_longitudinal`], [`psd_lateral`]).
//!
//! **Shaping filters and discretisation.** `u` is the first-order filter `1/(1 + Ts)`, `T = L/V`,
//! of white noise: an Ornstein–Uhlenbeck process, sampled exactly by
//! `u ← a·u + σ√(1−a²)·n`, `a = e^{−Δt/T}`. `v` and `w` are the MIL filter
//! `(1 + √3·Ts)/(1 + Ts)²`, realised as two cascaded first-order states `x₁' = (n − x₁)/T`,
//! `x₂' = (x₁ − x₂)/T` with output `(σ/√2)·(√3·x₁ + (1 − √3)·x₂)` (whose autocorrelation is exactly
//! `R_v` above, derivation in the tests). The 2-state system is discretised exactly: transition
//! `e^{AΔt} = a·[[1, 0], [d, 1]]`, `d = Δt/T`, and the driving noise's covariance
//! `Q = 2∫₀^d e^{−2s}[[1, s], [s, s²]] ds` in closed form (a series for small `d`, where the closed
//! form cancels), applied through its Cholesky factor. The samples therefore have the
//! continuous process's statistics exactly, at any step; the state starts in the stationary
//! distribution, so there is no start-up transient.
//!
//! **Hover.** Dryden's forms are written for an aircraft flying through frozen turbulence at
//! airspeed V (Taylor's hypothesis). A hovering drone has no airspeed of its own; the turbulence
//! is advected past it by the mean wind, so V here is the *advection speed*: the mean wind speed,
//! floored at [`ADVECTION_FLOOR_MPS`] so that turbulence in calm mean air still evolves (a
//! modelling choice, not from the MIL documents). The field is spatially uniform (one process for
//! the whole scene, as MuJoCo's global `opt.wind`): every drone feels the same gust at the same
//! instant.

use crate::noise::Gaussian;

/// Advection speed used when the mean wind is slower than this, m/s (see the module doc).
pub const ADVECTION_FLOOR_MPS: f64 = 1.0;

/// Feet per metre (the MIL formulas are in feet).
const FT_PER_M: f64 = 1.0 / 0.3048;

/// Lowest altitude of the MIL-HDBK-1797 low-altitude form, ft; lower flight uses it.
pub const LOW_ALTITUDE_FLOOR_FT: f64 = 10.0;

/// Why a turbulence process could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DrydenError {
    #[error("Dryden {what} = {value} must be finite and {bound}")]
    Parameter {
        what: &'static str,
        value: f64,
        bound: &'static str,
    },
}

/// Dryden parameters: intensities (σ, m/s), length scales (m) and the advection speed (m/s).
/// Axes: u along the mean wind (horizontal), v horizontal across it, w vertical (up).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DrydenParams {
    pub sigma_u_mps: f64,
    pub sigma_v_mps: f64,
    pub sigma_w_mps: f64,
    pub length_u_m: f64,
    pub length_v_m: f64,
    pub length_w_m: f64,
    /// V in the spectra: the speed at which the frozen field is advected past the drones.
    pub advection_mps: f64,
}

impl DrydenParams {
    /// MIL-HDBK-1797 low-altitude form (h < 1000 ft) with the horizontal intensity set directly:
    /// `σ_u = σ_v = sigma_horizontal_mps`, `σ_w = σ_u·(0.177 + 0.000823h)^0.4`,
    /// `L_u = L_v = h/(0.177 + 0.000823h)^1.2`, `L_w = h` (h in ft, here
    /// [`LOW_ALTITUDE_FLOOR_FT`]: the scene flies at ≈ 1.3 m, below the form's 10 ft floor).
    /// `length_horizontal_m` overrides `L_u = L_v`, and `L_w` keeps the form's ratio to it.
    /// Advection speed: `max(mean_wind_mps, ADVECTION_FLOOR_MPS)`.
    pub fn low_altitude(
        sigma_horizontal_mps: f64,
        length_horizontal_m: Option<f64>,
        mean_wind_mps: f64,
    ) -> Self {
        let h_ft = LOW_ALTITUDE_FLOOR_FT;
        let base = 0.177 + 0.000823 * h_ft;
        let form_lu_m = h_ft / base.powf(1.2) / FT_PER_M;
        let form_lw_m = h_ft / FT_PER_M;
        let lu = length_horizontal_m.unwrap_or(form_lu_m);
        Self {
            sigma_u_mps: sigma_horizontal_mps,
            sigma_v_mps: sigma_horizontal_mps,
            sigma_w_mps: sigma_horizontal_mps * base.powf(0.4),
            length_u_m: lu,
            length_v_m: lu,
            length_w_m: lu * form_lw_m / form_lu_m,
            advection_mps: mean_wind_mps.max(ADVECTION_FLOOR_MPS),
        }
    }

    fn check(&self) -> Result<(), DrydenError> {
        let nonneg = [
            ("σ_u", self.sigma_u_mps),
            ("σ_v", self.sigma_v_mps),
            ("σ_w", self.sigma_w_mps),
        ];
        for (what, value) in nonneg {
            if !(value.is_finite() && value >= 0.0) {
                return Err(DrydenError::Parameter {
                    what,
                    value,
                    bound: "≥ 0",
                });
            }
        }
        let positive = [
            ("L_u", self.length_u_m),
            ("L_v", self.length_v_m),
            ("L_w", self.length_w_m),
            ("V", self.advection_mps),
        ];
        for (what, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(DrydenError::Parameter {
                    what,
                    value,
                    bound: "> 0",
                });
            }
        }
        Ok(())
    }
}

/// Longitudinal autocorrelation `σ² e^{−Vτ/L}`, (m/s)².
pub fn autocorrelation_longitudinal(sigma_mps: f64, length_m: f64, v_mps: f64, lag_s: f64) -> f64 {
    sigma_mps * sigma_mps * (-v_mps * lag_s.abs() / length_m).exp()
}

/// Lateral/vertical autocorrelation `σ² (1 − Vτ/(2L)) e^{−Vτ/L}`, (m/s)².
pub fn autocorrelation_lateral(sigma_mps: f64, length_m: f64, v_mps: f64, lag_s: f64) -> f64 {
    let r = v_mps * lag_s.abs() / length_m;
    sigma_mps * sigma_mps * (1.0 - 0.5 * r) * (-r).exp()
}

/// Longitudinal one-sided PSD Φ_u(ω), (m/s)²/(rad/s).
pub fn psd_longitudinal(sigma_mps: f64, length_m: f64, v_mps: f64, omega_radps: f64) -> f64 {
    let x = length_m * omega_radps / v_mps;
    sigma_mps * sigma_mps * 2.0 * length_m / (std::f64::consts::PI * v_mps) / (1.0 + x * x)
}

/// Lateral/vertical one-sided PSD Φ_v(ω), (m/s)²/(rad/s).
pub fn psd_lateral(sigma_mps: f64, length_m: f64, v_mps: f64, omega_radps: f64) -> f64 {
    let x2 = (length_m * omega_radps / v_mps).powi(2);
    sigma_mps * sigma_mps * length_m / (std::f64::consts::PI * v_mps) * (1.0 + 3.0 * x2)
        / ((1.0 + x2) * (1.0 + x2))
}

/// `∫₀^d sⁿ e^{−2s} ds` for n = 0, 1, 2.
fn moments(d: f64) -> [f64; 3] {
    if d < 0.5 {
        // Σ_k (−2)^k d^{n+k+1} / (k! (n+k+1)): converges fast and never cancels badly here.
        let mut out = [0.0; 3];
        for (n, o) in out.iter_mut().enumerate() {
            let mut term = d.powi(n as i32 + 1); // (−2d)^k/k! · d^{n+1}
            let mut k = 0;
            loop {
                let add = term / (n + k + 1) as f64;
                *o += add;
                if add.abs() <= 1e-18 * o.abs() || k > 60 {
                    break;
                }
                k += 1;
                term *= -2.0 * d / k as f64;
            }
        }
        out
    } else {
        let e = (-2.0 * d).exp();
        let i0 = 0.5 * (1.0 - e);
        let i1 = -0.5 * d * e + 0.5 * i0;
        let i2 = -0.5 * d * d * e + i1;
        [i0, i1, i2]
    }
}

/// First-order Dryden component (longitudinal).
#[derive(Debug, Clone)]
struct FirstOrder {
    a: f64,
    gain: f64,
    sigma: f64,
    x: f64,
    noise: Gaussian,
}

impl FirstOrder {
    fn new(sigma: f64, t_s: f64, dt_s: f64, mut noise: Gaussian) -> Self {
        let d = dt_s / t_s;
        let a = (-d).exp();
        // 1 − a² without cancellation.
        let gain = (-(-2.0 * d).exp_m1()).sqrt();
        let x = noise.normal();
        Self {
            a,
            gain,
            sigma,
            x,
            noise,
        }
    }

    fn value(&self) -> f64 {
        self.sigma * self.x
    }

    fn step(&mut self) {
        self.x = self.a * self.x + self.gain * self.noise.normal();
    }
}

/// Second-order Dryden component (lateral or vertical).
#[derive(Debug, Clone)]
struct SecondOrder {
    a: f64,
    d: f64,
    /// Cholesky factor of the per-step noise covariance: l11, l21, l22.
    chol: [f64; 3],
    sigma: f64,
    x: [f64; 2],
    noise: Gaussian,
}

impl SecondOrder {
    fn new(sigma: f64, t_s: f64, dt_s: f64, mut noise: Gaussian) -> Self {
        let d = dt_s / t_s;
        let [i0, i1, i2] = moments(d);
        let (q11, q12, q22) = (2.0 * i0, 2.0 * i1, 2.0 * i2);
        let l11 = q11.sqrt();
        let l21 = q12 / l11;
        let l22 = (q22 - l21 * l21).max(0.0).sqrt();
        // Stationary covariance [[1, ½], [½, ½]]: x₂ = ½x₁ + ½n.
        let x1 = noise.normal();
        let x2 = 0.5 * x1 + 0.5 * noise.normal();
        Self {
            a: (-d).exp(),
            d,
            chol: [l11, l21, l22],
            sigma,
            x: [x1, x2],
            noise,
        }
    }

    fn value(&self) -> f64 {
        let s3 = 3f64.sqrt();
        self.sigma * std::f64::consts::FRAC_1_SQRT_2 * (s3 * self.x[0] + (1.0 - s3) * self.x[1])
    }

    fn step(&mut self) {
        let [x1, x2] = self.x;
        let (n1, n2) = (self.noise.normal(), self.noise.normal());
        let [l11, l21, l22] = self.chol;
        self.x = [
            self.a * x1 + l11 * n1,
            self.a * (self.d * x1 + x2) + l21 * n1 + l22 * n2,
        ];
    }
}

/// A seeded Dryden process sampled every `step_ns`: `[u, v, w]`, m/s, in the turbulence axes
/// (u along the mean wind, v across it, w up).
#[derive(Debug, Clone)]
pub struct Dryden {
    params: DrydenParams,
    step_ns: u64,
    u: FirstOrder,
    v: SecondOrder,
    w: SecondOrder,
}

impl Dryden {
    /// The process of `params`, sampled every `step_ns`, its noise drawn from `seed`.
    pub fn new(params: DrydenParams, step_ns: u64, seed: u64) -> Result<Self, DrydenError> {
        params.check()?;
        if step_ns == 0 {
            return Err(DrydenError::Parameter {
                what: "step (ns)",
                value: 0.0,
                bound: "> 0",
            });
        }
        let dt_s = step_ns as f64 * 1e-9;
        let v = params.advection_mps;
        Ok(Self {
            params,
            step_ns,
            u: FirstOrder::new(
                params.sigma_u_mps,
                params.length_u_m / v,
                dt_s,
                Gaussian::new(seed, 1),
            ),
            v: SecondOrder::new(
                params.sigma_v_mps,
                params.length_v_m / v,
                dt_s,
                Gaussian::new(seed, 2),
            ),
            w: SecondOrder::new(
                params.sigma_w_mps,
                params.length_w_m / v,
                dt_s,
                Gaussian::new(seed, 3),
            ),
        })
    }

    /// The parameters.
    pub fn params(&self) -> &DrydenParams {
        &self.params
    }

    /// The sampling step, ns.
    pub fn step_ns(&self) -> u64 {
        self.step_ns
    }

    /// The current sample `[u, v, w]`, m/s.
    pub fn gust_mps(&self) -> [f64; 3] {
        [self.u.value(), self.v.value(), self.w.value()]
    }

    /// Advances one step and returns the new sample `[u, v, w]`, m/s.
    pub fn advance(&mut self) -> [f64; 3] {
        self.u.step();
        self.v.step();
        self.w.step();
        self.gust_mps()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_covariance_series_matches_closed_form() {
        for d in [1e-4_f64, 1e-2, 0.3, 0.49] {
            let e = (-2.0 * d).exp();
            let i0 = 0.5 * (1.0 - e);
            let i1 = -0.5 * d * e + 0.5 * i0;
            let i2 = -0.5 * d * d * e + i1;
            let s = moments(d);
            for (a, b) in s.iter().zip([i0, i1, i2]) {
                assert!(
                    (a - b).abs() <= 1e-9 * b.abs().max(1e-30) + 1e-17,
                    "{d}: {a} {b}"
                );
            }
        }
    }

    #[test]
    fn low_altitude_form_at_ten_feet() {
        let p = DrydenParams::low_altitude(1.0, None, 0.0);
        // (0.177 + 0.00823)^0.4 = 0.5094; L_u = 10 ft / 0.18523^1.2 = 75.6 ft = 23.05 m.
        assert!((p.sigma_w_mps - 0.5094).abs() < 1e-3, "{p:?}");
        assert!((p.length_u_m - 23.05).abs() < 0.05, "{p:?}");
        assert!((p.length_w_m - 3.048).abs() < 1e-9, "{p:?}");
        assert_eq!(p.advection_mps, ADVECTION_FLOOR_MPS);
        let q = DrydenParams::low_altitude(1.0, Some(10.0), 3.0);
        assert_eq!((q.length_v_m, q.advection_mps), (10.0, 3.0));
        assert!((q.length_w_m / q.length_u_m - p.length_w_m / p.length_u_m).abs() < 1e-12);
    }
}
