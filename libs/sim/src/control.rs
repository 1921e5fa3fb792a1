//! Ideal world-frame force/torque stabilisation of a drone towards a reference.
//!
//! The paper's drones are "ideally stabilised": the controller applies a world-frame force at the
//! centre of mass and a torque, with no rotor model. Position is a PD loop with velocity and
//! acceleration feed-forward plus exact gravity compensation; attitude is a PD loop towards level
//! flight at the reference yaw.

use proto::Kinematics;

/// Where a drone should be: a [`Kinematics`] (position plus velocity and acceleration
/// feed-forward) flown at heading `yaw_rad`. World frame, SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reference {
    pub kin: Kinematics,
    pub yaw_rad: f64,
}

impl Reference {
    /// Fly `kin` at heading `yaw_rad`.
    pub fn new(kin: Kinematics, yaw_rad: f64) -> Self {
        Self { kin, yaw_rad }
    }

    /// A stationary hover at `pos_m` with heading `yaw_rad`.
    pub fn hover(pos_m: [f64; 3], yaw_rad: f64) -> Self {
        Self::new(Kinematics::rest(pos_m), yaw_rad)
    }

    /// The reference advanced by `dt_s` under constant acceleration (used between 40 ms ticks);
    /// the heading is held.
    pub fn extrapolated(&self, dt_s: f64) -> Self {
        Self::new(self.kin.extrapolated(dt_s), self.yaw_rad)
    }
}

/// Controller gains. Position: natural frequency 8 rad/s, critically damped (no overshoot on a
/// step, settles in < 1 s). Attitude: 40 rad/s, critically damped.
#[derive(Debug, Clone, Copy)]
pub struct Gains {
    pub pos_wn_radps: f64,
    pub att_wn_radps: f64,
}

impl Default for Gains {
    fn default() -> Self {
        Self {
            pos_wn_radps: 8.0,
            att_wn_radps: 40.0,
        }
    }
}

/// Measured state of a drone: world position, world linear velocity, orientation quaternion
/// (w, x, y, z; `world_from_body`) and body-frame angular velocity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DroneState {
    pub pos_m: [f64; 3],
    pub vel_mps: [f64; 3],
    pub world_from_body: [f64; 4],
    pub body_rate_radps: [f64; 3],
}

/// Computes the world-frame `[force (N); torque (N·m)]` to apply at the centre of mass.
pub fn wrench(
    state: &DroneState,
    reference: &Reference,
    mass_kg: f64,
    inertia_kgm2: [f64; 3],
    gravity_mps2: f64,
    gains: &Gains,
) -> [f64; 6] {
    let kp = gains.pos_wn_radps * gains.pos_wn_radps;
    let kd = 2.0 * gains.pos_wn_radps;
    let mut out = [0.0; 6];
    let want = &reference.kin;
    for k in 0..3 {
        let acc = want.acc_mps2[k]
            + kp * (want.pos_m[k] - state.pos_m[k])
            + kd * (want.vel_mps[k] - state.vel_mps[k]);
        out[k] = mass_kg * acc;
    }
    out[2] += mass_kg * gravity_mps2;

    // Attitude error: q_err = q_des⁻¹ ⊗ q, small-angle vector 2·sign(w)·vec(q_err), in body frame.
    let half = 0.5 * reference.yaw_rad;
    let q_des_inv = [half.cos(), 0.0, 0.0, -half.sin()];
    let q_err = quat_mul(q_des_inv, state.world_from_body);
    let sign = if q_err[0] < 0.0 { -1.0 } else { 1.0 };
    let kr = gains.att_wn_radps * gains.att_wn_radps;
    let kw = 2.0 * gains.att_wn_radps;
    let mut torque_body = [0.0; 3];
    for k in 0..3 {
        let err = 2.0 * sign * q_err[k + 1];
        torque_body[k] = inertia_kgm2[k] * (-kr * err - kw * state.body_rate_radps[k]);
    }
    let torque_world = rotate(state.world_from_body, torque_body);
    out[3..].copy_from_slice(&torque_world);
    out
}

fn quat_mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

/// Rotates vector `v` by unit quaternion `q` (w, x, y, z).
pub fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
    let p = quat_mul(
        quat_mul(q, [0.0, v[0], v[1], v[2]]),
        [q[0], -q[1], -q[2], -q[3]],
    );
    [p[1], p[2], p[3]]
}

/// Yaw (rotation about world z) of `world_from_body`.
pub fn yaw_of(q: [f64; 4]) -> f64 {
    (2.0 * (q[0] * q[3] + q[1] * q[2])).atan2(1.0 - 2.0 * (q[2] * q[2] + q[3] * q[3]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hover_at_reference_needs_exactly_gravity_compensation() {
        let state = DroneState {
            pos_m: [0.0, 0.0, 1.3],
            vel_mps: [0.0; 3],
            world_from_body: [1.0, 0.0, 0.0, 0.0],
            body_rate_radps: [0.0; 3],
        };
        let w = wrench(
            &state,
            &Reference::hover([0.0, 0.0, 1.3], 0.0),
            0.027,
            [1.0; 3],
            9.81,
            &Gains::default(),
        );
        assert_eq!(w, [0.0, 0.0, 0.027 * 9.81, 0.0, 0.0, 0.0]);
    }

    #[test]
    fn yaw_error_produces_restoring_torque() {
        let yaw = 0.1_f64;
        let state = DroneState {
            pos_m: [0.0; 3],
            vel_mps: [0.0; 3],
            world_from_body: [(yaw / 2.0).cos(), 0.0, 0.0, (yaw / 2.0).sin()],
            body_rate_radps: [0.0; 3],
        };
        let w = wrench(
            &state,
            &Reference::hover([0.0; 3], 0.0),
            0.027,
            [1.0; 3],
            0.0,
            &Gains::default(),
        );
        assert!(w[5] < 0.0, "torque {w:?}");
        assert!((yaw_of(state.world_from_body) - yaw).abs() < 1e-12);
    }
}
