//! The state estimate a realistic flight controller sees: the true position and velocity,
//! delayed by the estimator's latency and corrupted by seeded, time-correlated noise.
//!
//! Model (a modelling choice, stated): an on-board EKF fusing an external position system
//! (Crazyflie Lighthouse or UWB) gives position errors of a few centimetres that wander slowly,
//! and velocity errors of a few cm/s that wander faster. Each axis's error is a first-order
//! Gauss–Markov (Ornstein–Uhlenbeck) process with σ and correlation time τ, sampled exactly each
//! physics step; the estimate is the true state `latency_ns` ago (rounded to whole physics steps)
//! plus that error. Attitude and body rates come from the IMU and are used as they are: gyro
//! noise and attitude-estimate latency are far below the position errors this study is about.

use std::collections::VecDeque;

use crate::control::DroneState;
use crate::noise::{Gaussian, mix};

/// Estimator noise and latency.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EstimateConfig {
    /// σ of each position axis's error, m.
    pub position_sigma_m: f64,
    /// Correlation time of the position error, s.
    pub position_tau_s: f64,
    /// σ of each velocity axis's error, m/s.
    pub velocity_sigma_mps: f64,
    /// Correlation time of the velocity error, s.
    pub velocity_tau_s: f64,
    /// Age of the estimate, ns (rounded to whole physics steps).
    pub latency_ns: u64,
    /// Seed of the noise (a `perturb::seed` stream); each drone mixes in its index.
    pub seed: u64,
}

impl Default for EstimateConfig {
    /// 2 cm position σ wandering over 0.2 s, 5 cm/s velocity σ over 20 ms, 4 ms old.
    fn default() -> Self {
        Self {
            position_sigma_m: 0.02,
            position_tau_s: 0.2,
            velocity_sigma_mps: 0.05,
            velocity_tau_s: 0.02,
            latency_ns: 4_000_000,
            seed: 0,
        }
    }
}

/// Velocity-error σ per metre of position-error σ, 1/s: the default's 5 cm/s at 2 cm, so that
/// one knob (`flight.estimate_sigma_m`) scales the whole estimate's quality.
pub const VELOCITY_PER_POSITION_SIGMA_PS: f64 = 2.5;

impl EstimateConfig {
    /// The perturbation terms' estimate: position σ `position_sigma_m`, velocity σ
    /// [`VELOCITY_PER_POSITION_SIGMA_PS`] times it, the default correlation times, `latency_ns`.
    pub fn from_terms(position_sigma_m: f64, latency_ns: u64, seed: u64) -> Self {
        Self {
            position_sigma_m,
            velocity_sigma_mps: VELOCITY_PER_POSITION_SIGMA_PS * position_sigma_m,
            latency_ns,
            seed,
            ..Self::default()
        }
    }

    /// A perfect estimate: no noise, no latency.
    pub fn perfect() -> Self {
        Self {
            position_sigma_m: 0.0,
            velocity_sigma_mps: 0.0,
            latency_ns: 0,
            ..Self::default()
        }
    }
}

/// One axis's Gauss–Markov error, sampled exactly every step.
#[derive(Debug, Clone)]
struct GaussMarkov {
    a: f64,
    drive: f64,
    x: f64,
}

impl GaussMarkov {
    fn new(sigma: f64, tau_s: f64, dt_s: f64, noise: &mut Gaussian) -> Self {
        let d = if tau_s > 0.0 {
            dt_s / tau_s
        } else {
            f64::INFINITY
        };
        Self {
            a: (-d).exp(),
            drive: sigma * (-(-2.0 * d).exp_m1()).sqrt(),
            x: sigma * noise.normal(),
        }
    }

    fn step(&mut self, noise: &mut Gaussian) -> f64 {
        self.x = self.a * self.x + self.drive * noise.normal();
        self.x
    }
}

/// A drone's delayed, noisy state estimate.
#[derive(Debug, Clone)]
pub struct Estimator {
    delay_steps: usize,
    history: VecDeque<DroneState>,
    position: [GaussMarkov; 3],
    velocity: [GaussMarkov; 3],
    noise: Gaussian,
    noisy: bool,
}

impl Estimator {
    /// The estimator of `config` for drone `drone` stepped every `step_ns`.
    pub fn new(config: &EstimateConfig, step_ns: u64, drone: usize) -> Self {
        let dt_s = step_ns as f64 * 1e-9;
        let mut noise = Gaussian::new(mix(config.seed), drone as u64);
        let mut gm = |sigma, tau| GaussMarkov::new(sigma, tau, dt_s, &mut noise);
        let (ps, pt) = (config.position_sigma_m, config.position_tau_s);
        let (vs, vt) = (config.velocity_sigma_mps, config.velocity_tau_s);
        let position = [gm(ps, pt), gm(ps, pt), gm(ps, pt)];
        let velocity = [gm(vs, vt), gm(vs, vt), gm(vs, vt)];
        let delay_steps = ((config.latency_ns + step_ns / 2) / step_ns.max(1)) as usize;
        Self {
            delay_steps,
            history: VecDeque::with_capacity(delay_steps + 1),
            position,
            velocity,
            noise,
            noisy: config.position_sigma_m > 0.0 || config.velocity_sigma_mps > 0.0,
        }
    }

    /// Forgets the delay line (the noise processes continue).
    pub fn clear(&mut self) {
        self.history.clear();
    }

    /// Latency in whole steps.
    pub fn delay_steps(&self) -> usize {
        self.delay_steps
    }

    /// Takes this step's true state; returns the estimate the controller sees now. Call exactly
    /// once per physics step (the noise advances with it).
    pub fn observe(&mut self, truth: &DroneState) -> DroneState {
        self.history.push_back(*truth);
        while self.history.len() > self.delay_steps + 1 {
            self.history.pop_front();
        }
        // Until the line has filled, the oldest state stands in for the missing past.
        let old = self.history.front().copied().unwrap_or(*truth);
        let mut est = DroneState {
            world_from_body: truth.world_from_body,
            body_rate_radps: truth.body_rate_radps,
            ..old
        };
        if self.noisy {
            for k in 0..3 {
                est.pos_m[k] += self.position[k].step(&mut self.noise);
                est.vel_mps[k] += self.velocity[k].step(&mut self.noise);
            }
        }
        est
    }
}
