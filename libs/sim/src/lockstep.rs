//! The simulator's side of the lockstep, in one place for `sim-node` (the processes) and
//! `waggle mission` (one process), so that both fly and see exactly the same thing:
//!
//! - [`sim_state`]: the ground truth as the simulator publishes it (`sim/state`), read from the
//!   kinematics MuJoCo computed at the start of the last step;
//! - [`mirror`]: a camera's copy of the world posed from that truth, which is what it renders;
//! - [`TickReferences`]: tick k's performer setpoint and scheduler command, extrapolated inside
//!   the tick with their feed-forward velocity and acceleration.
//!
//! docs/DESIGN.md §3 describes the lockstep these serve.

use std::collections::BTreeMap;

use proto::{DronePose, PerformerSetpoint, SchedCommand, SimState};

use crate::control::Reference;
use crate::world::{DroneIndex, World};

/// Why a camera could not mirror a `sim/state`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MirrorError {
    #[error("sim/state at {stamp_ns} ns lacks drone {name}")]
    MissingDrone { name: String, stamp_ns: u64 },
}

/// `world`'s ground truth now, labelled as part of tick `tick` (the tick whose interval the
/// instant ends or lies in).
pub fn sim_state(world: &World, tick: u64) -> SimState {
    let drones = world
        .drone_names()
        .iter()
        .enumerate()
        .map(|(i, name)| {
            let (pos_m, quat_wxyz) = world.body_pose(i);
            let s = world.state(i);
            DronePose {
                name: name.clone(),
                pos_m,
                quat_wxyz,
                vel_mps: s.vel_mps,
                ang_vel_radps: s.body_rate_radps,
            }
        })
        .collect();
    SimState {
        tick,
        stamp_ns: world.time_ns(),
        drones,
    }
}

/// Poses every drone of `world` as in `state`, at its instant, for rendering (a camera never
/// steps physics).
pub fn mirror(world: &mut World, state: &SimState) -> Result<(), MirrorError> {
    for i in 0..world.drone_names().len() {
        let name = &world.drone_names()[i];
        let Some(d) = state.drone(name) else {
            return Err(MirrorError::MissingDrone {
                name: name.clone(),
                stamp_ns: state.stamp_ns,
            });
        };
        let (pos_m, quat_wxyz) = (d.pos_m, d.quat_wxyz);
        world.set_pose(i, pos_m, quat_wxyz);
    }
    world.forward_at(state.stamp_ns);
    Ok(())
}

/// The references of one tick: what the performer and the scheduler asked for at t_k.
#[derive(Debug, Clone)]
pub struct TickReferences {
    t_k_ns: u64,
    performer: Reference,
    observers: Vec<(DroneIndex, Reference)>,
}

impl TickReferences {
    /// Tick references from the performer's `setpoint{k}` and the scheduler's `cmd{k}`, with
    /// the world at t_k. Setpoints for drones the scene lacks are ignored (the command is
    /// validated upstream); observers without a setpoint keep their last reference.
    pub fn new(world: &World, setpoint: &PerformerSetpoint, cmd: &SchedCommand) -> Self {
        let index: BTreeMap<&str, DroneIndex> = world
            .drone_names()
            .iter()
            .enumerate()
            .map(|(i, n)| (n.as_str(), i))
            .collect();
        Self {
            t_k_ns: world.time_ns(),
            performer: Reference::new(setpoint.kinematics(), setpoint.yaw_rad),
            observers: cmd
                .setpoints
                .iter()
                .filter_map(|s| {
                    index
                        .get(s.observer.as_str())
                        .map(|&i| (i, Reference::new(s.kinematics(), s.yaw_rad)))
                })
                .collect(),
        }
    }

    /// Sets every reference, extrapolated to the world's current instant; call before each
    /// physics step of the tick.
    pub fn apply(&self, world: &mut World) {
        let dt_s = world.time_ns().saturating_sub(self.t_k_ns) as f64 * 1e-9;
        world.set_reference(0, self.performer.extrapolated(dt_s));
        for (i, r) in &self.observers {
            world.set_reference(*i, r.extrapolated(dt_s));
        }
    }
}
