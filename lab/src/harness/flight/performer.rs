//! The performer's broadcast schedule as physics references, for the in-process harnesses
//! (`waggle link`, `waggle mission`, the report's sensor figure).

use proto::{Kinematics, Schedule};
use sim::control::Reference;
use sim::world::{DroneIndex, World};

/// The performer is drone 0 of every generated scene.
const PERFORMER: DroneIndex = 0;

/// The performer flies level, facing +x, whatever its schedule does.
pub fn performer_reference(sp: Kinematics) -> Reference {
    Reference::new(sp, 0.0)
}

/// Commands the performer to where `schedule` has it now, then advances physics one step.
pub fn step_along(world: &mut World, schedule: &Schedule) {
    let reference = performer_reference(schedule.state_at(world.time_ns()));
    world.set_reference(PERFORMER, reference);
    world.step();
}
