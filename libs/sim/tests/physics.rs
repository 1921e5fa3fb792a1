//! Physics: hover accuracy, step response and contact bookkeeping on the real MuJoCo scene.

use proto::scene::{PERFORMER_HOVER_M, distance_m};
use sim::control::Reference;
use sim::world::World;

const SECOND_NS: u64 = 1_000_000_000;

#[test]
fn every_drone_holds_its_setpoint_within_a_millimetre() {
    let mut world = World::new(3).expect("scene");
    world.step_until(2 * SECOND_NS);
    for _ in 0..500 {
        world.step();
        for i in 0..4 {
            let err = distance_m(world.position_m(i), world.reference(i).kin.pos_m);
            assert!(
                err < 1e-3,
                "drone {i} off its setpoint by {err} m at {} ns",
                world.time_ns()
            );
        }
    }
    assert_eq!(
        world.time_ns(),
        3 * SECOND_NS,
        "integer clock: 1500 steps of 2 ms"
    );
}

#[test]
fn a_20_cm_step_settles_within_two_seconds_without_overshoot() {
    let mut world = World::new(1).expect("scene");
    world.step_until(SECOND_NS);
    let start = world.position_m(0);
    let target = [start[0] + 0.2, start[1], start[2]];
    world.set_reference(0, Reference::hover(target, 0.0));
    let t0 = world.time_ns();
    let mut max_x = f64::NEG_INFINITY;
    let mut settled_at = None;
    while world.time_ns() < t0 + 3 * SECOND_NS {
        world.step();
        let p = world.position_m(0);
        max_x = max_x.max(p[0]);
        let err = distance_m(p, target);
        if err < 0.02 * 0.2 {
            settled_at.get_or_insert(world.time_ns() - t0);
        } else {
            settled_at = None;
        }
    }
    let overshoot = (max_x - target[0]) / 0.2;
    assert!(overshoot <= 0.10, "overshoot {:.1} %", overshoot * 100.0);
    let settled = settled_at.expect("never settled to 2 %");
    assert!(settled <= 2 * SECOND_NS, "settled after {settled} ns");
}

#[test]
fn drones_commanded_into_each_other_register_contact_steps() {
    let mut world = World::new(1).expect("scene");
    world.step_until(SECOND_NS);
    assert_eq!(
        world.contact_stats().contact_steps,
        0,
        "separated drones touch"
    );
    let stats = world.contact_stats();
    assert!(stats.min_separation_m > 1.2, "{stats:?}");
    // Command the observer onto the performer's hover point.
    let target = PERFORMER_HOVER_M;
    let yaw = world.reference(1).yaw_rad;
    world.set_reference(1, Reference::hover(target, yaw));
    world.step_until(4 * SECOND_NS);
    let stats = world.contact_stats();
    assert!(stats.contact_steps > 0, "no contact recorded: {stats:?}");
    assert!(stats.min_separation_m < 0.15, "{stats:?}");
}
