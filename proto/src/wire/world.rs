//! Ground truth from the simulator (`sim/state`, `sim/contacts`) and the performer's own
//! topics (`performer/setpoint`, `truth/performer`). Observers never subscribe to any of these.

use serde::{Deserialize, Serialize};

use crate::clock::{check_finite, stamp_in_tick};
use crate::codec::Validate;
use crate::keys::validate_chunk;
use crate::payload::Offer;
use crate::token::Action;

/// Position, velocity and acceleration of one drone at one instant (world frame, SI units): the
/// one kinematic-state type of the workspace (performer schedule, scheduler trajectories,
/// setpoints and physics references).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Kinematics {
    pub pos_m: [f64; 3],
    pub vel_mps: [f64; 3],
    pub acc_mps2: [f64; 3],
}

impl Kinematics {
    /// At rest at `pos_m`.
    pub fn rest(pos_m: [f64; 3]) -> Self {
        Self {
            pos_m,
            vel_mps: [0.0; 3],
            acc_mps2: [0.0; 3],
        }
    }

    /// The state advanced by `dt_s` under constant acceleration (the simulator's extrapolation
    /// of a setpoint between 40 ms ticks).
    pub fn extrapolated(&self, dt_s: f64) -> Self {
        let mut out = *self;
        for k in 0..3 {
            out.pos_m[k] += self.vel_mps[k] * dt_s + 0.5 * self.acc_mps2[k] * dt_s * dt_s;
            out.vel_mps[k] += self.acc_mps2[k] * dt_s;
        }
        out
    }
}

/// Ground-truth pose and velocity of one drone.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DronePose {
    /// `performer` or an observer id (`O1`, …).
    pub name: String,
    pub pos_m: [f64; 3],
    /// Orientation quaternion (w, x, y, z), unit norm.
    pub quat_wxyz: [f64; 4],
    pub vel_mps: [f64; 3],
    pub ang_vel_radps: [f64; 3],
}

/// Poses of every drone at one render instant of tick `tick`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SimState {
    pub tick: u64,
    /// The render instant, in `(t_{tick−1}, t_tick]`.
    pub stamp_ns: u64,
    pub drones: Vec<DronePose>,
}

impl SimState {
    pub fn drone(&self, name: &str) -> Option<&DronePose> {
        self.drones.iter().find(|d| d.name == name)
    }
}

impl Validate for SimState {
    fn validate(&self) -> Result<(), String> {
        if !stamp_in_tick(self.stamp_ns, self.tick) {
            return Err(format!(
                "sim state at {} ns is outside tick {}",
                self.stamp_ns, self.tick
            ));
        }
        let mut names = std::collections::BTreeSet::new();
        for d in &self.drones {
            validate_chunk("drone", &d.name).map_err(|e| e.to_string())?;
            if !names.insert(d.name.as_str()) {
                return Err(format!("drone {} appears twice", d.name));
            }
            check_finite(&format!("drone {} position", d.name), &d.pos_m)?;
            check_finite(&format!("drone {} quaternion", d.name), &d.quat_wxyz)?;
            check_finite(&format!("drone {} velocity", d.name), &d.vel_mps)?;
            check_finite(
                &format!("drone {} angular velocity", d.name),
                &d.ang_vel_radps,
            )?;
            let norm = d.quat_wxyz.iter().map(|q| q * q).sum::<f64>().sqrt();
            if (norm - 1.0).abs() > 1e-3 {
                return Err(format!("drone {} quaternion has norm {norm}", d.name));
            }
        }
        Ok(())
    }
}

/// One physics step with a contact between two geoms.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Contact {
    pub step_ns: u64,
    pub body_a: String,
    pub body_b: String,
    /// Penetration depth (positive = overlapping), metres.
    pub depth_m: f64,
}

/// Contacts of one tick (published every tick; empty when nothing touched), with the running
/// totals since the start so a late subscriber still learns the mission's figures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SimContacts {
    pub tick: u64,
    pub contacts: Vec<Contact>,
    /// Physics steps with at least one drone–drone contact, since the start.
    pub contact_steps: u64,
    /// Minimum body-centre distance over all drone pairs and steps since the start, m.
    pub min_separation_m: f64,
}

impl Validate for SimContacts {
    fn validate(&self) -> Result<(), String> {
        for c in &self.contacts {
            if !stamp_in_tick(c.step_ns, self.tick) {
                return Err(format!(
                    "contact at {} ns is outside tick {}",
                    c.step_ns, self.tick
                ));
            }
            check_finite("contact depth", &[c.depth_m])?;
            if c.body_a.is_empty() || c.body_b.is_empty() {
                return Err("contact with an unnamed body".into());
            }
        }
        if self.min_separation_m.is_nan() || self.min_separation_m < 0.0 {
            return Err(format!(
                "minimum separation {} m is not a distance",
                self.min_separation_m
            ));
        }
        Ok(())
    }
}

/// The performer's flight setpoint for the next tick (same wire layout as the flat fields: the
/// tick, then `kin`'s position, velocity, acceleration, then the yaw).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PerformerSetpoint {
    /// The tick this setpoint answers (it applies while stepping tick + 1).
    pub tick: u64,
    pub kin: Kinematics,
    pub yaw_rad: f64,
}

impl PerformerSetpoint {
    /// The setpoint of tick `tick`: `kin` flown at heading `yaw_rad`.
    pub fn new(tick: u64, kin: Kinematics, yaw_rad: f64) -> Self {
        Self { tick, kin, yaw_rad }
    }

    /// Position, velocity and acceleration of the setpoint.
    pub fn kinematics(&self) -> Kinematics {
        self.kin
    }
}

impl Validate for PerformerSetpoint {
    fn validate(&self) -> Result<(), String> {
        check_finite("performer setpoint position", &self.kin.pos_m)?;
        check_finite("performer setpoint velocity", &self.kin.vel_mps)?;
        check_finite("performer setpoint acceleration", &self.kin.acc_mps2)?;
        check_finite("performer setpoint yaw", &[self.yaw_rad])
    }
}

/// What the performer is flying, for the record only.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum PerformerActivity {
    /// Hovering with nothing to send.
    Idle,
    /// The event version's left–right acquisition motion.
    Acquisition,
    /// A NULL hover inside or around a frame.
    NullHover,
    /// One of the four actions.
    Action(Action),
}

/// Ground-truth label of the performer's motion (`truth/performer`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct PerformerTruth {
    pub tick: u64,
    pub stamp_ns: u64,
    pub round: u32,
    pub activity: PerformerActivity,
    /// The offer being sent, while inside a frame.
    pub offer: Option<Offer>,
    /// Position 0–16 in the frame, while inside a frame.
    pub frame_slot: Option<u8>,
}

impl Validate for PerformerTruth {
    fn validate(&self) -> Result<(), String> {
        if !stamp_in_tick(self.stamp_ns, self.tick) {
            return Err(format!(
                "truth at {} ns is outside tick {}",
                self.stamp_ns, self.tick
            ));
        }
        if let Some(o) = self.offer {
            o.check().map_err(|e| e.to_string())?;
        }
        if self
            .frame_slot
            .is_some_and(|s| usize::from(s) >= crate::frame::MAX_FRAME_TOKENS)
        {
            return Err(format!(
                "frame slot {:?} beyond the longest frame",
                self.frame_slot
            ));
        }
        Ok(())
    }
}
