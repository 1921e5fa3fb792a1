//! A Crazyflie-like cascaded flight controller: position → velocity → attitude → body rate, with
//! integral action on velocity, the Crazyflie's thrust and tilt limits, a motor mixer with
//! per-motor saturation, and a delayed noisy state estimate ([`crate::estimate`]).
//!
//! Structure and limits follow the Crazyflie firmware's default PID controller
//! (`position_controller_pid.c`, `attitude_pid_controller.c`, `power_distribution_quadrotor.c`):
//! a P position loop whose output is a velocity setpoint capped at 1 m/s (`xyVelMax`, `zVelMax`),
//! a PI velocity loop producing an acceleration, turned into a collective thrust and a tilt capped
//! at 20° (`rpLimit`), a P attitude loop producing body rates and a P rate loop producing
//! torques. Gains are SI, not copies of the firmware's PWM-unit numbers: position 2 /s (the
//! firmware's `xKp`), velocity 5 /s (its 25 °/(m/s) ≈ 4.3 m/s² per m/s), a velocity integral of
//! 2 /s² (stronger than the firmware's 1 °/(m/s·s), so a wind is rejected within seconds), and
//! an attitude loop of 20 /s over a 100 /s rate loop. The firmware's attitude gain is 6 /s; with
//! it our loop tracked a 0.3 m, 0.5 Hz sway with 5 cm of resonant error, more than a real
//! Crazyflie shows, so the attitude loop is faster here. Differences, stated: every loop runs at
//! the 500 Hz physics rate (the firmware runs position at 100 Hz), the reference's velocity and
//! acceleration are fed forward, and the integrators are frozen while tilt or thrust saturates.
//!
//! The output is physical: a collective thrust along body z plus body torques, applied as a
//! world-frame wrench at the centre of mass, so a horizontal force needs a real tilt.

use crate::control::{DroneState, Reference, rotate};
use crate::estimate::{EstimateConfig, Estimator};
use crate::vec3::{cross, dot};

/// Loop gains, SI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CascadeGains {
    /// Position error → velocity setpoint, 1/s (horizontal, vertical).
    pub pos_kp_ps: [f64; 2],
    /// Velocity error → acceleration, 1/s (horizontal, vertical).
    pub vel_kp_ps: [f64; 2],
    /// Integrated velocity error → acceleration, 1/s² (horizontal, vertical).
    pub vel_ki_ps2: [f64; 2],
    /// Attitude error → body-rate setpoint, 1/s (roll/pitch, yaw).
    pub att_kp_ps: [f64; 2],
    /// Body-rate error → angular acceleration, 1/s.
    pub rate_kp_ps: f64,
}

impl Default for CascadeGains {
    fn default() -> Self {
        Self {
            pos_kp_ps: [2.0, 2.0],
            vel_kp_ps: [5.0, 8.0],
            vel_ki_ps2: [2.0, 6.0],
            att_kp_ps: [20.0, 6.0],
            rate_kp_ps: 100.0,
        }
    }
}

/// Actuator and setpoint limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CascadeLimits {
    /// Maximum thrust of one motor, N. Crazyflie 2.x: ≈ 0.149 N (thrust-to-weight 2.25 at
    /// 27 g, gym-pybullet-drones `cf2x.urdf`; Bitcraze quote ≈ 60 g total).
    pub max_motor_thrust_n: f64,
    /// Maximum tilt of the thrust setpoint from vertical, rad (firmware `rpLimit` = 20°).
    pub max_tilt_rad: f64,
    /// Cap of the position loop's velocity correction, m/s (horizontal norm, vertical).
    pub max_vel_mps: [f64; 2],
    /// Cap of each axis's integral term, m/s².
    pub max_integral_mps2: f64,
    /// Motor arm along each body axis, m (motors at (±a, ±a)).
    pub arm_m: f64,
    /// Yaw torque per newton of motor thrust, m (km/kf, cf2x.urdf: 7.94e-12/3.16e-10).
    pub torque_per_thrust_m: f64,
}

impl Default for CascadeLimits {
    fn default() -> Self {
        Self {
            max_motor_thrust_n: 2.25 * 0.027 * 9.81 / 4.0,
            max_tilt_rad: 20f64.to_radians(),
            max_vel_mps: [1.0, 1.0],
            max_integral_mps2: 2.0,
            arm_m: 0.0325,
            torque_per_thrust_m: 7.94e-12 / 3.16e-10,
        }
    }
}

/// Everything the cascade needs.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CascadeConfig {
    pub gains: CascadeGains,
    pub limits: CascadeLimits,
    pub estimate: EstimateConfig,
}

impl CascadeConfig {
    /// The Crazyflie defaults with the perturbation terms' estimate
    /// ([`EstimateConfig::from_terms`]).
    pub fn from_terms(estimate_sigma_m: f64, estimate_latency_ns: u64, seed: u64) -> Self {
        Self {
            estimate: EstimateConfig::from_terms(estimate_sigma_m, estimate_latency_ns, seed),
            ..Self::default()
        }
    }
}

/// What the cascade commanded on its last update.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CascadeCommand {
    /// Collective thrust after the mixer, N.
    pub thrust_n: f64,
    /// Torques after the mixer, body frame, N·m.
    pub torque_body_nm: [f64; 3],
    /// Each motor's thrust, N.
    pub motor_thrust_n: [f64; 4],
    /// Tilt of the thrust setpoint from vertical, rad (≤ the limit).
    pub tilt_setpoint_rad: f64,
    /// The estimate the controller acted on.
    pub estimate: Option<DroneState>,
}

/// One drone's cascade: integrator, estimator and last command.
#[derive(Debug, Clone)]
pub struct Cascade {
    config: CascadeConfig,
    dt_s: f64,
    integral_mps2: [f64; 3],
    estimator: Estimator,
    last: CascadeCommand,
}

/// Body `x`, `y`, `z` axes (rotation matrix columns) of `q` (w, x, y, z).
fn axes(q: [f64; 4]) -> [[f64; 3]; 3] {
    [
        rotate(q, [1.0, 0.0, 0.0]),
        rotate(q, [0.0, 1.0, 0.0]),
        rotate(q, [0.0, 0.0, 1.0]),
    ]
}

fn unit(a: [f64; 3]) -> [f64; 3] {
    let n = dot(a, a).sqrt();
    [a[0] / n, a[1] / n, a[2] / n]
}

impl Cascade {
    /// The cascade of `config` for drone `drone` (its estimator's noise stream), updated every
    /// `step_ns`.
    pub fn new(config: CascadeConfig, step_ns: u64, drone: usize) -> Self {
        Self {
            config,
            dt_s: step_ns as f64 * 1e-9,
            integral_mps2: [0.0; 3],
            estimator: Estimator::new(&config.estimate, step_ns, drone),
            last: CascadeCommand::default(),
        }
    }

    /// Forgets the integrators, the estimate history and the last command (the estimate noise
    /// stream continues).
    pub fn reset(&mut self) {
        self.integral_mps2 = [0.0; 3];
        self.estimator.clear();
        self.last = CascadeCommand::default();
    }

    /// The last command.
    pub fn last_command(&self) -> CascadeCommand {
        self.last
    }

    /// One control update from the true state `truth` (seen through the estimator): the
    /// world-frame `[force (N); torque (N·m)]` to apply at the centre of mass.
    pub fn update(
        &mut self,
        truth: &DroneState,
        reference: &Reference,
        mass_kg: f64,
        inertia_kgm2: [f64; 3],
        gravity_mps2: f64,
    ) -> [f64; 6] {
        let est = self.estimator.observe(truth);
        let acc = self.acceleration(&est, reference);
        let (thrust_sp, tilt, z_des) = self.thrust_vector(acc, mass_kg, gravity_mps2);
        let torque_sp = self.torques(&est, reference.yaw_rad, z_des, inertia_kgm2);
        let (motors, thrust, torque_body) = self.mix(thrust_sp, torque_sp);
        self.last = CascadeCommand {
            thrust_n: thrust,
            torque_body_nm: torque_body,
            motor_thrust_n: motors,
            tilt_setpoint_rad: tilt,
            estimate: Some(est),
        };
        // The physics applies thrust and torque through the *true* attitude.
        let q = truth.world_from_body;
        let f = rotate(q, [0.0, 0.0, thrust]);
        let t = rotate(q, torque_body);
        [f[0], f[1], f[2], t[0], t[1], t[2]]
    }

    /// Position and velocity loops: the commanded acceleration, world frame, m/s².
    fn acceleration(&mut self, est: &DroneState, reference: &Reference) -> [f64; 3] {
        let g = &self.config.gains;
        let lim = &self.config.limits;
        let want = &reference.kin;
        let mut corr = [0.0; 3];
        for k in 0..3 {
            let h = usize::from(k == 2);
            corr[k] = g.pos_kp_ps[h] * (want.pos_m[k] - est.pos_m[k]);
        }
        // Velocity correction capped like the firmware's xyVelMax / zVelMax.
        let horiz = corr[0].hypot(corr[1]);
        if horiz > lim.max_vel_mps[0] {
            let s = lim.max_vel_mps[0] / horiz;
            corr[0] *= s;
            corr[1] *= s;
        }
        corr[2] = corr[2].clamp(-lim.max_vel_mps[1], lim.max_vel_mps[1]);
        // Anti-windup: no horizontal integration while the tilt was saturated, no vertical while
        // the thrust was (conditional integration on the last command), and a cap.
        let tilt_saturated = self.last.tilt_setpoint_rad >= lim.max_tilt_rad - 1e-9;
        let thrust_saturated = self.last.thrust_n >= 4.0 * lim.max_motor_thrust_n - 1e-9;
        let mut acc = [0.0; 3];
        for k in 0..3 {
            let h = usize::from(k == 2);
            let err = want.vel_mps[k] + corr[k] - est.vel_mps[k];
            let frozen = if k == 2 {
                thrust_saturated
            } else {
                tilt_saturated
            };
            if !frozen {
                let cap = lim.max_integral_mps2;
                self.integral_mps2[k] =
                    (self.integral_mps2[k] + g.vel_ki_ps2[h] * err * self.dt_s).clamp(-cap, cap);
            }
            acc[k] = want.acc_mps2[k] + g.vel_kp_ps[h] * err + self.integral_mps2[k];
        }
        acc
    }

    /// Thrust setpoint (N), its tilt (rad) and desired body z axis from the commanded
    /// acceleration, with the tilt limit applied and the vertical component kept.
    fn thrust_vector(&self, acc: [f64; 3], mass_kg: f64, gravity: f64) -> (f64, f64, [f64; 3]) {
        let lim = &self.config.limits;
        // Motors cannot pull down: keep a small upward component to define the axis.
        let fz = (mass_kg * (acc[2] + gravity)).max(0.05 * mass_kg * gravity);
        let (mut fx, mut fy) = (mass_kg * acc[0], mass_kg * acc[1]);
        let horiz = fx.hypot(fy);
        let max_horiz = fz * lim.max_tilt_rad.tan();
        if horiz > max_horiz {
            let s = max_horiz / horiz;
            fx *= s;
            fy *= s;
        }
        let f = [fx, fy, fz];
        let tilt = fx.hypot(fy).atan2(fz);
        (dot(f, f).sqrt(), tilt, unit(f))
    }

    /// Attitude and rate loops: body torques (N·m) to turn body z onto `z_des` at `yaw_rad`.
    fn torques(
        &self,
        est: &DroneState,
        yaw_rad: f64,
        z_des: [f64; 3],
        inertia: [f64; 3],
    ) -> [f64; 3] {
        let g = &self.config.gains;
        let x_c = [yaw_rad.cos(), yaw_rad.sin(), 0.0];
        let y_des = unit(cross(z_des, x_c));
        let x_des = cross(y_des, z_des);
        let rd = [x_des, y_des, z_des];
        let r = axes(est.world_from_body);
        // e_R = ½ vee(R_dᵀR − RᵀR_d) (Lee, Leok & McClamroch 2010), body frame.
        let m = |i: usize, j: usize| dot(rd[i], r[j]) - dot(r[i], rd[j]);
        let e_r = [0.5 * m(2, 1), 0.5 * m(0, 2), 0.5 * m(1, 0)];
        let w = est.body_rate_radps;
        let rate_sp = [
            -g.att_kp_ps[0] * e_r[0],
            -g.att_kp_ps[0] * e_r[1],
            -g.att_kp_ps[1] * e_r[2],
        ];
        let iw = [inertia[0] * w[0], inertia[1] * w[1], inertia[2] * w[2]];
        let gyro = cross(w, iw);
        let mut tau = [0.0; 3];
        for k in 0..3 {
            tau[k] = inertia[k] * g.rate_kp_ps * (rate_sp[k] - w[k]) + gyro[k];
        }
        tau
    }

    /// X-configuration mixer with per-motor saturation: motors at (a, −a), (−a, −a), (−a, a),
    /// (a, a), alternating spin. When a motor would exceed its maximum, collective thrust is
    /// given up first (as the firmware's power distribution does), then each motor is clamped.
    fn mix(&self, thrust: f64, tau: [f64; 3]) -> ([f64; 4], f64, [f64; 3]) {
        let lim = &self.config.limits;
        let a = lim.arm_m;
        let c = lim.torque_per_thrust_m;
        let pos = [[a, -a], [-a, -a], [-a, a], [a, a]];
        let spin = [1.0, -1.0, 1.0, -1.0];
        let mut t = [0.0; 4];
        for i in 0..4 {
            let [x, y] = pos[i];
            t[i] = thrust / 4.0
                + tau[0] * y / (4.0 * a * a)
                + tau[1] * (-x) / (4.0 * a * a)
                + tau[2] * spin[i] / (4.0 * c);
        }
        let over = t.iter().copied().fold(f64::NEG_INFINITY, f64::max) - lim.max_motor_thrust_n;
        if over > 0.0 {
            t.iter_mut().for_each(|ti| *ti -= over);
        }
        t.iter_mut()
            .for_each(|ti| *ti = ti.clamp(0.0, lim.max_motor_thrust_n));
        let mut out_t = 0.0;
        let mut out_tau = [0.0; 3];
        for i in 0..4 {
            let [x, y] = pos[i];
            out_t += t[i];
            out_tau[0] += y * t[i];
            out_tau[1] += -x * t[i];
            out_tau[2] += spin[i] * c * t[i];
        }
        (t, out_t, out_tau)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mixer_round_trips_and_saturates() {
        let c = Cascade::new(CascadeConfig::default(), 2_000_000, 0);
        let (m, t, tau) = c.mix(0.3, [1e-4, -2e-4, 5e-5]);
        assert!((t - 0.3).abs() < 1e-12, "{t}");
        assert!((tau[0] - 1e-4).abs() < 1e-12 && (tau[1] + 2e-4).abs() < 1e-12);
        assert!((tau[2] - 5e-5).abs() < 1e-12, "{tau:?} {m:?}");
        let (m, t, _) = c.mix(2.0, [0.0; 3]);
        let max = c.config.limits.max_motor_thrust_n;
        assert!(m.iter().all(|&x| x <= max) && t <= 4.0 * max + 1e-12);
    }

    #[test]
    fn tilt_setpoint_is_capped() {
        let c = Cascade::new(CascadeConfig::default(), 2_000_000, 0);
        let (_, tilt, z) = c.thrust_vector([50.0, 0.0, 0.0], 0.027, 9.81);
        assert!((tilt - 20f64.to_radians()).abs() < 1e-12, "{tilt}");
        assert!((z[2] - tilt.cos()).abs() < 1e-12);
    }
}
