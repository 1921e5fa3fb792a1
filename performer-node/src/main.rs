//! `performer-node --session S`: the performer process.
//!
//! Per tick k it takes the scheduler's `sched/broadcast{k}` — published every tick, with the
//! broadcast that starts at t_k if there is one — and answers with `performer/setpoint{k}`
//! (position, velocity and acceleration of its schedule at t_k; the simulator extrapolates them
//! over tick k+1) and `truth/performer{k}` (what it is flying, for the record only). The
//! broadcast message doubles as the tick barrier, so the performer needs no clock of its own.

use std::time::Duration;

use anyhow::{Context, Result};
use bus::{Bus, Inbound, NodeArgs, Process, Rejects};
use clap::Parser;
use proto::{
    BroadcastTick, Offer, PerformerActivity, PerformerSetpoint, PerformerTruth, RejectReason, Role,
    TICK_NS,
};
use proto::{GestureConfig, Schedule, broadcast, performer_setpoint};

#[derive(Parser)]
#[command(
    name = "performer-node",
    version,
    about = "The Waggle performer process"
)]
struct Args {
    #[command(flatten)]
    node: NodeArgs,
    #[command(flatten)]
    own: node_args::PerformerArgs,
}

/// The performer's answer to one tick.
fn answer(
    schedule: Option<&Schedule>,
    round: u32,
    tick: u64,
) -> (PerformerSetpoint, PerformerTruth) {
    let t = tick * TICK_NS;
    let span = schedule.and_then(|s| s.spans_at(t).next().copied());
    let truth = PerformerTruth {
        tick,
        stamp_ns: t,
        round,
        activity: span.map_or(PerformerActivity::Idle, |s| s.symbol.activity()),
        offer: span
            .and_then(|s| s.slot)
            .and_then(|slot| Offer::from_payload(slot.payload).ok()),
        frame_slot: span.and_then(|s| s.slot).map(|slot| slot.position),
    };
    (performer_setpoint(schedule, tick), truth)
}

fn main() -> Result<()> {
    node_args::init_logging();
    let args = Args::parse();
    let node = &args.node;
    let gesture = GestureConfig::default();
    let mut bus = Bus::open_node(node).context("opening the Zenoh session")?;
    let keys = bus.keys().clone();
    bus.subscribe(&keys.sched_broadcast())?;
    node.join(&mut bus, &Process::singleton(Role::Performer))
        .context("start-up handshake")?;
    let sim_alive = keys.alive(Role::Sim, Role::Sim.as_str())?;
    let scheduler_alive = keys.alive(Role::Scheduler, Role::Scheduler.as_str())?;
    let mut schedule: Option<Schedule> = None;
    let mut round = 0;
    let mut rejects = Rejects::new(Role::Performer.as_str(), &keys);
    // The scheduler sends one broadcast tick per clock tick, in order, from tick 0.
    let mut next_tick = 0u64;
    loop {
        match bus.recv(Duration::from_millis(200)) {
            Some(Inbound::Data { key, payload }) if key == keys.sched_broadcast() => {
                let Some(msg) = rejects.decode::<BroadcastTick>(&key, &payload) else {
                    continue;
                };
                if msg.tick != next_tick {
                    rejects.reject(
                        &key,
                        RejectReason::OutOfContract,
                        &format_args!("broadcast tick {} while tick {next_tick} is due", msg.tick),
                    );
                    continue;
                }
                if let Some(b) = &msg.broadcast {
                    let payloads: Vec<u8> = b.offers.iter().map(|o| o.to_payload()).collect();
                    match broadcast(
                        b.start_ns,
                        &payloads,
                        b.acquisition,
                        &gesture,
                        args.own.frame_check,
                    ) {
                        Ok(s) => {
                            schedule = Some(s);
                            round = b.round;
                            tracing::info!(
                                tick = b.tick,
                                round,
                                offers = payloads.len(),
                                "broadcast"
                            );
                        }
                        Err(e) => {
                            rejects.reject(&key, RejectReason::OutOfContract, &e);
                            continue;
                        }
                    }
                }
                next_tick += 1;
                let (setpoint, truth) = answer(schedule.as_ref(), round, msg.tick);
                bus.put(&keys.performer_setpoint(), &setpoint)?;
                bus.put(&keys.truth_performer(), &truth)?;
            }
            Some(Inbound::Data { key, .. }) => {
                rejects.reject(&key, RejectReason::UnexpectedKey, &"not subscribed");
            }
            _ => {
                if !bus.is_alive(&sim_alive) && !bus.is_alive(&scheduler_alive) {
                    break;
                }
            }
        }
    }
    bus.put(
        &keys.rejects(Role::Performer, Role::Performer.as_str())?,
        &rejects.report(),
    )?;
    bus.close()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proto::paper_broadcast;
    use proto::scene::PERFORMER_HOVER_M;

    #[test]
    fn idle_performer_hovers_and_a_broadcast_moves_it_with_labels() {
        let (sp, truth) = answer(None, 0, 7);
        assert_eq!(sp.kin.pos_m, PERFORMER_HOVER_M);
        assert_eq!(truth.activity, PerformerActivity::Idle);
        assert_eq!(truth.stamp_ns, 7 * TICK_NS);
        let s = paper_broadcast(0, &[0b011010], false).unwrap();
        let moving = (0..20_000u64)
            .map(|k| answer(Some(&s), 1, k))
            .find(|(sp, _)| sp.kin.vel_mps.iter().any(|v| v.abs() > 1e-6))
            .expect("the schedule moves");
        assert!(matches!(moving.1.activity, PerformerActivity::Action(_)));
        assert_eq!(moving.1.offer, Some(Offer::from_payload(0b011010).unwrap()));
        assert!(moving.1.frame_slot.is_some());
    }
}
