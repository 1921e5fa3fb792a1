//! Wind and the cascade controller on the real MuJoCo scene: the drag a hovering drone feels,
//! step-force rejection, thrust and tilt limits, determinism, and that the default world is
//! untouched by the options.

use proto::scene::distance_m;
use sim::cascade::CascadeConfig;
use sim::control::{Reference, rotate};
use sim::estimate::EstimateConfig;
use sim::mjcf::{DRONE_MASS_KG, PHYSICS_STEP_NS};
use sim::wind::dryden::DrydenParams;
use sim::wind::{RotorDrag, WindConfig};
use sim::world::{ControllerKind, World};

const SECOND_NS: u64 = 1_000_000_000;

fn steady_wind(mean_mps: f64, direction_deg: f64) -> WindConfig {
    WindConfig::from_terms(mean_mps, direction_deg, 0.0, 0.0, 0)
}

fn perfect_cascade() -> ControllerKind {
    ControllerKind::Cascade(CascadeConfig {
        estimate: EstimateConfig::perfect(),
        ..CascadeConfig::default()
    })
}

/// Tilt of body z from world z, rad.
fn tilt_rad(q: [f64; 4]) -> f64 {
    rotate(q, [0.0, 0.0, 1.0])[2].clamp(-1.0, 1.0).acos()
}

#[test]
fn a_hovering_drone_in_a_2_mps_wind_feels_the_calibrated_drag() {
    // The ideal controller is a PD without integral: at rest its restoring force m·ω²·e balances
    // whatever force the wind exerts, so the offset measures the force in the physics.
    let mut world = World::new(2).expect("scene");
    world.set_wind(Some(steady_wind(2.0, 30.0))).unwrap();
    world.step_until(4 * SECOND_NS);
    let model = RotorDrag::crazyflie();
    let expected_n = model.k_xy_nspm * 2.0;
    for i in 0..3 {
        let s = world.state(i);
        let r = world.reference(i).kin.pos_m;
        let kp = 8.0 * 8.0;
        let f: Vec<f64> = (0..3)
            .map(|k| DRONE_MASS_KG * kp * (s.pos_m[k] - r[k]))
            .collect();
        let mag = f[0].hypot(f[1]);
        let dir = f[1].atan2(f[0]).to_degrees();
        println!(
            "drone {i}: measured {:.3} mN towards {dir:.2}°, model {:.3} mN ({:+.2} %); vertical {:.2e} N",
            mag * 1e3,
            expected_n * 1e3,
            (mag / expected_n - 1.0) * 100.0,
            f[2]
        );
        assert!((mag / expected_n - 1.0).abs() < 0.05, "drone {i}: {mag} N");
        assert!((dir - 30.0).abs() < 1.0, "drone {i}: direction {dir}");
        assert!(f[2].abs() < 0.05 * expected_n);
    }
    // 11.1 mN: the figure of the doc comment (Förster 2015 via cf2x.urdf).
    assert!((expected_n - 0.01113).abs() < 2e-5, "{expected_n}");
}

#[test]
fn the_default_world_is_untouched_by_the_options() {
    let mut plain = World::new(2).expect("scene");
    let mut reset = World::new(2).expect("scene");
    reset.set_controller(perfect_cascade());
    reset.set_controller(ControllerKind::Ideal);
    reset.set_wind(Some(steady_wind(3.0, 0.0))).unwrap();
    reset.set_wind(None).unwrap();
    for w in [&mut plain, &mut reset] {
        w.set_reference(0, Reference::hover([0.3, 0.1, 1.4], 0.2));
        w.step_until(SECOND_NS);
    }
    for i in 0..3 {
        let (a, b) = (plain.state(i), reset.state(i));
        assert_eq!(a.pos_m.map(f64::to_bits), b.pos_m.map(f64::to_bits));
        assert_eq!(
            a.world_from_body.map(f64::to_bits),
            b.world_from_body.map(f64::to_bits)
        );
    }
    assert!(plain.wind_mps().is_none() && plain.cascade_command(0).is_none());
}

#[test]
fn one_drone_can_fly_the_cascade_alone() {
    let mut mixed = World::new(2).expect("scene");
    let mut plain = World::new(2).expect("scene");
    mixed.set_controller_of(0, perfect_cascade());
    assert!(mixed.cascade_command(0).is_some() && mixed.cascade_command(1).is_none());
    mixed.step_until(SECOND_NS);
    plain.step_until(SECOND_NS);
    // The observers still fly the ideal controller, bit for bit.
    for i in 1..3 {
        let (a, b) = (mixed.state(i), plain.state(i));
        assert_eq!(a.pos_m.map(f64::to_bits), b.pos_m.map(f64::to_bits));
    }
    assert!(mixed.cascade_command(0).is_some_and(|c| c.thrust_n > 0.2));
}

#[test]
fn the_ideal_controller_tracks_a_hover_to_a_millimetre() {
    let mut world = World::new(1).expect("scene");
    world.step_until(2 * SECOND_NS);
    world.reset_tracking();
    world.step_until(3 * SECOND_NS);
    let t = world.tracking_error(0);
    assert_eq!(t.steps, 500);
    assert!(t.max_m < 1e-3 && t.rms_m <= t.max_m, "{t:?}");
}

#[test]
fn the_cascade_rejects_a_step_force_with_zero_steady_error() {
    let mut world = World::new(1).expect("scene");
    world.set_controller(perfect_cascade());
    world.step_until(3 * SECOND_NS);
    let home = world.reference(0).kin.pos_m;
    let before = distance_m(world.state(0).pos_m, home);
    assert!(before < 1e-4, "hover error {before}");
    // 20 mN sideways and down: 7 % of the weight, twice the drag of a 2 m/s wind.
    world.set_disturbance_n(0, [0.015, -0.01, -0.008]);
    let mut peak: f64 = 0.0;
    while world.time_ns() < 23 * SECOND_NS {
        world.step();
        peak = peak.max(distance_m(world.state(0).pos_m, home));
    }
    world.reset_tracking();
    world.step_until(25 * SECOND_NS);
    let t = world.tracking_error(0);
    println!(
        "step force: peak deviation {:.2} mm, last 2 s max {:.4} mm",
        peak * 1e3,
        t.max_m * 1e3
    );
    assert!(peak > 5e-3, "the force did move the drone: {peak}");
    assert!(t.max_m < 2e-4, "steady error {t:?}");
    // Holding position against a horizontal force needs a real tilt.
    let tilt = tilt_rad(world.state(0).world_from_body).to_degrees();
    let want = (0.015f64.hypot(0.01) / (DRONE_MASS_KG * 9.81 - 0.008))
        .atan()
        .to_degrees();
    assert!((tilt - want).abs() < 0.3, "tilt {tilt}° vs {want}°");
}

#[test]
fn the_cascade_holds_a_steady_wind_with_zero_steady_error() {
    let mut world = World::new(1).expect("scene");
    world.set_controller(perfect_cascade());
    world.set_wind(Some(steady_wind(3.0, 120.0))).unwrap();
    world.step_until(20 * SECOND_NS);
    world.reset_tracking();
    world.step_until(22 * SECOND_NS);
    for i in 0..2 {
        let t = world.tracking_error(i);
        assert!(t.max_m < 2e-4, "drone {i}: {t:?}");
    }
}

/// Maxima over 2 s after commanding a jump of `offset_m` with feed-forward `acc_mps2`: total
/// thrust, any motor's thrust, tilt setpoint and body tilt. Asserts every motor stays in range.
fn limits_run(config: CascadeConfig, offset_m: [f64; 3], acc_mps2: [f64; 3]) -> [f64; 4] {
    let mut world = World::new(1).expect("scene");
    world.set_controller(ControllerKind::Cascade(config));
    world.step_until(SECOND_NS);
    let p = world.reference(0).kin.pos_m;
    let mut far = Reference::hover(
        [p[0] + offset_m[0], p[1] + offset_m[1], p[2] + offset_m[2]],
        0.0,
    );
    far.kin.acc_mps2 = acc_mps2;
    world.set_reference(0, far);
    let mut max = [0.0f64; 4];
    while world.time_ns() < 3 * SECOND_NS {
        world.step();
        let c = world.cascade_command(0).expect("cascade");
        let motor_max = config.limits.max_motor_thrust_n;
        assert!(
            c.motor_thrust_n
                .iter()
                .all(|&m| (0.0..=motor_max).contains(&m)),
            "{c:?}"
        );
        let motor = c.motor_thrust_n.iter().copied().fold(0.0, f64::max);
        let body = tilt_rad(world.state(0).world_from_body);
        for (m, v) in max
            .iter_mut()
            .zip([c.thrust_n, motor, c.tilt_setpoint_rad, body])
        {
            *m = m.max(v);
        }
    }
    max
}

#[test]
fn the_cascade_respects_its_thrust_and_tilt_limits() {
    let config = CascadeConfig {
        estimate: EstimateConfig::perfect(),
        ..CascadeConfig::default()
    };
    let max_motor = config.limits.max_motor_thrust_n;
    let max_tilt = config.limits.max_tilt_rad;
    // Straight up with 2 g demanded: thrust saturates.
    let [thrust, motor, _, _] = limits_run(config, [0.0, 0.0, 3.0], [0.0, 0.0, 20.0]);
    println!(
        "climb: max thrust {thrust:.4} N (limit {:.4}), max motor {motor:.4} N",
        4.0 * max_motor
    );
    assert!(thrust <= 4.0 * max_motor + 1e-12);
    assert!(thrust > 0.95 * 4.0 * max_motor, "thrust near its limit");
    assert_eq!(motor, max_motor, "a motor saturated");
    // 4 m sideways with 6 m/s² demanded: tilt saturates.
    let [_, _, tilt_sp, tilt_body] = limits_run(config, [4.0, -1.0, 0.0], [6.0, 0.0, 0.0]);
    println!(
        "dash: max tilt setpoint {:.3}°, max body tilt {:.3}° (limit {:.1}°)",
        tilt_sp.to_degrees(),
        tilt_body.to_degrees(),
        max_tilt.to_degrees()
    );
    assert!(tilt_sp <= max_tilt + 1e-12);
    assert!(tilt_sp > max_tilt - 1e-6, "the tilt limit was reached");
    assert!(
        tilt_body < max_tilt + 3f64.to_radians(),
        "body tilt {tilt_body}"
    );
}

fn gusty_cascade_world(seed: u64) -> World {
    let mut world = World::new(2).expect("scene");
    world.set_controller(ControllerKind::Cascade(CascadeConfig {
        estimate: EstimateConfig {
            seed,
            ..EstimateConfig::default()
        },
        ..CascadeConfig::default()
    }));
    let wind = WindConfig::from_terms(1.5, 45.0, 0.8, 0.0, seed);
    assert!(
        wind.turbulence
            .is_some_and(|t: DrydenParams| t.sigma_u_mps == 0.8)
    );
    world.set_wind(Some(wind)).unwrap();
    world
}

#[test]
fn same_seeds_fly_the_same_trajectory_bit_for_bit() {
    let (mut a, mut b, mut c) = (
        gusty_cascade_world(11),
        gusty_cascade_world(11),
        gusty_cascade_world(12),
    );
    let mut differ = false;
    for _ in 0..1500 {
        a.step();
        b.step();
        c.step();
        for i in 0..3 {
            let (x, y) = (a.state(i), b.state(i));
            assert_eq!(x.pos_m.map(f64::to_bits), y.pos_m.map(f64::to_bits));
            assert_eq!(x.vel_mps.map(f64::to_bits), y.vel_mps.map(f64::to_bits));
            differ |= x.pos_m != c.state(i).pos_m;
        }
    }
    assert!(differ, "another seed flies another trajectory");
}

#[test]
fn a_realistic_estimate_costs_centimetres_of_hover_accuracy() {
    let mut world = World::new(1).expect("scene");
    world.set_controller(ControllerKind::Cascade(CascadeConfig {
        estimate: EstimateConfig {
            seed: 3,
            ..EstimateConfig::default()
        },
        ..CascadeConfig::default()
    }));
    world.step_until(2 * SECOND_NS);
    world.reset_tracking();
    world.step_until(12 * SECOND_NS);
    let t = world.tracking_error(0);
    println!(
        "hover with the default estimate: RMS {:.2} mm, max {:.2} mm",
        t.rms_m * 1e3,
        t.max_m * 1e3
    );
    assert!(t.rms_m > 2e-3 && t.rms_m < 0.05, "{t:?}");
    assert_eq!(t.steps, 10 * SECOND_NS / PHYSICS_STEP_NS);
}

#[test]
fn turbulence_moves_the_ideal_performer_by_millimetres() {
    let mut world = World::new(1).expect("scene");
    world
        .set_wind(Some(WindConfig::from_terms(2.0, 0.0, 1.0, 0.0, 9)))
        .unwrap();
    world.step_until(2 * SECOND_NS);
    world.reset_tracking();
    world.step_until(12 * SECOND_NS);
    let t = world.tracking_error(0);
    println!(
        "ideal controller, 2 m/s mean + σ 1 m/s: RMS {:.2} mm, max {:.2} mm",
        t.rms_m * 1e3,
        t.max_m * 1e3
    );
    assert!(t.rms_m > 1e-3, "{t:?}");
}

/// A gesture-like sway from rest: 0.3 m peak to peak at 0.5 Hz along y (peak 0.47 m/s,
/// 1.5 m/s²), with its velocity and acceleration fed forward.
fn sway(home: [f64; 3], t_s: f64) -> Reference {
    let (a, w) = (0.15, std::f64::consts::PI);
    let (s, c) = (w * t_s).sin_cos();
    let mut r = Reference::hover([home[0], home[1] + a * (1.0 - c), home[2]], 0.0);
    r.kin.vel_mps[1] = a * w * s;
    r.kin.acc_mps2[1] = a * w * w * c;
    r
}

fn sway_error(controller: ControllerKind, wind: Option<WindConfig>) -> sim::world::TrackingError {
    let mut world = World::new(1).expect("scene");
    world.set_controller(controller);
    world.set_wind(wind).unwrap();
    let home = world.reference(0).kin.pos_m;
    world.step_until(2 * SECOND_NS);
    world.reset_tracking();
    while world.time_ns() < 12 * SECOND_NS {
        let t_s = (world.time_ns() - 2 * SECOND_NS) as f64 * 1e-9;
        world.set_reference(0, sway(home, t_s));
        world.step();
    }
    world.tracking_error(0)
}

#[test]
fn tracking_error_of_a_sway_by_controller_and_wind() {
    let gusts = Some(WindConfig::from_terms(2.0, 90.0, 1.0, 0.0, 4));
    let cascade = ControllerKind::Cascade(CascadeConfig::from_terms(0.02, 4_000_000, 4));
    let rows = [
        ("ideal, calm", sway_error(ControllerKind::Ideal, None)),
        (
            "ideal, 2 m/s + σ 1 m/s",
            sway_error(ControllerKind::Ideal, gusts),
        ),
        (
            "cascade (perfect estimate), calm",
            sway_error(perfect_cascade(), None),
        ),
        ("cascade, calm", sway_error(cascade, None)),
        ("cascade, 2 m/s + σ 1 m/s", sway_error(cascade, gusts)),
    ];
    for (name, t) in &rows {
        println!(
            "{name}: RMS {:.2} mm, max {:.2} mm",
            t.rms_m * 1e3,
            t.max_m * 1e3
        );
    }
    assert!(rows[0].1.max_m < 2e-3, "{:?}", rows[0]);
    assert!(rows[4].1.rms_m > rows[0].1.rms_m);
    assert!(rows[4].1.rms_m < 0.1, "{:?}", rows[4]);
}
