//! The gesture generator against the ideal receiver: every observer decodes what was flown.

use evaluation::IdealReceiver;
use proto::frame::frame_tokens;
use proto::scene::{MAX_OBSERVERS, PERFORMER_HOVER_M};
use proto::{Action, Token};
use proto::{
    GestureConfig, NS_PER_MS, NS_PER_S, Schedule, ScheduleBuilder, TruthSymbol, broadcast,
    paper_broadcast,
};
use proto::{Interruption, SegmenterConfig, TokenCause};

/// RGB receiver rate.
const PERIOD_NS: u64 = 40 * NS_PER_MS;

fn configs() -> [(&'static str, SegmenterConfig); 2] {
    [
        ("rgb", SegmenterConfig::rgb()),
        ("events", SegmenterConfig::events()),
    ]
}

fn run(schedule: &Schedule, n: usize, config: SegmenterConfig, from_ns: u64) -> IdealReceiver {
    let mut r = IdealReceiver::new(n, config).unwrap();
    r.run_setpoints(schedule, from_ns, schedule.end_ns() + NS_PER_S, PERIOD_NS)
        .unwrap();
    r
}

fn tokens_of(r: &IdealReceiver, i: usize) -> Vec<Token> {
    r.output(i)
        .unwrap()
        .tokens
        .iter()
        .map(|t| t.token)
        .collect()
}

#[test]
fn each_symbol_flown_alone_is_classified_as_itself_by_every_observer() {
    for n in 1..=MAX_OBSERVERS {
        for action in Action::ALL {
            let mut b =
                ScheduleBuilder::new(0, PERFORMER_HOVER_M, GestureConfig::default()).unwrap();
            b.null(5 * NS_PER_S)
                .unwrap()
                .action(action)
                .unwrap()
                .null(5 * NS_PER_S)
                .unwrap();
            let s = b.build();
            for (name, config) in configs() {
                let r = run(&s, n, config, 0);
                for i in 0..n {
                    let o = r.output(i).unwrap();
                    assert_eq!(
                        tokens_of(&r, i),
                        vec![Token::Null, action.token(), Token::Null],
                        "N={n} {name} {} flying {action}: {:?}",
                        o.name,
                        o.tokens
                    );
                    let TokenCause::Classified(c) = o.tokens[1].cause else {
                        unreachable!()
                    };
                    println!(
                        "N={n} {name} {} {action}: error {:.3}, runner-up {:.3}, span {:.0} px",
                        o.name, c.error, c.runner_up_error, c.span_px
                    );
                    assert!(
                        c.span_px > 60.0,
                        "N={n} {} {action}: span {} px",
                        o.name,
                        c.span_px
                    );
                    assert!(
                        c.error < 0.11,
                        "N={n} {} {action}: error {}",
                        o.name,
                        c.error
                    );
                    // The action is confirmed with the NULL that ends it, inside the final hold
                    // (the rest counts from when the point came within the anchor radius of
                    // where it settles, so during the last stroke's deceleration).
                    let end_hold = s.timeline()[2];
                    assert!(
                        o.tokens[1].stamp_ns >= end_hold.start_ns + NS_PER_S,
                        "N={n} {} {action}: NULL {} ns into the hold",
                        o.name,
                        o.tokens[1].stamp_ns as i64 - end_hold.start_ns as i64
                    );
                    assert!(o.tokens[1].stamp_ns + NS_PER_S < end_hold.end_ns);
                }
            }
        }
    }
}

#[test]
fn symbols_have_modest_peak_speed_and_acceleration() {
    let config = GestureConfig::default();
    for action in Action::ALL {
        let mut b = ScheduleBuilder::new(0, PERFORMER_HOVER_M, config).unwrap();
        b.action(action).unwrap();
        let s = b.build();
        let (v, a) = s.peak_motion(0, s.end_ns());
        println!("{action}: peak speed {v:.3} m/s, peak acceleration {a:.3} m/s²");
        assert!(v < 0.35 && a < 0.6, "{action}: {v} m/s, {a} m/s²");
        assert!(v > 0.1, "{action} is implausibly slow: {v} m/s");
    }
}

#[test]
fn two_consecutive_offers_release_exactly_those_payloads_in_order() {
    for n in 1..=MAX_OBSERVERS {
        every_observer_of_n_releases_both_offers(n);
    }
}

/// The built-in formation of `n` observers: each one releases both frames, token by token.
fn every_observer_of_n_releases_both_offers(n: usize) {
    let payloads = [0b011010, 0b100111];
    for acquisition in [false, true] {
        let s = paper_broadcast(5 * NS_PER_S, &payloads, acquisition).unwrap();
        for (name, config) in configs() {
            let r = run(&s, n, config, 0);
            for i in 0..n {
                let o = r.output(i).unwrap();
                assert_eq!(
                    o.payloads(),
                    payloads.to_vec(),
                    "N={n} {name} acq={acquisition} {}",
                    o.name
                );
                // Token stream: the pre-broadcast hover NULL, (the sweep as Unknown and its
                // NULL), then both frames sharing the hover between them, nothing else.
                let mut want = vec![Token::Null];
                if acquisition {
                    want.extend([Token::Unknown, Token::Null]);
                }
                want.extend(frame_tokens(payloads[0]).iter().skip(1));
                want.extend(frame_tokens(payloads[1]).iter().skip(1));
                assert_eq!(
                    tokens_of(&r, i),
                    want,
                    "{name} acq={acquisition} {}",
                    o.name
                );
                // Every released token was confirmed inside the truth span it stands for (an
                // action is confirmed with the NULL after it, so inside that NULL's span).
                for (k, f) in o.frames.iter().enumerate() {
                    let spans: Vec<_> = s
                        .timeline()
                        .iter()
                        .filter(|sp| sp.slot.is_some_and(|sl| sl.offer_index == k as u32))
                        .collect();
                    for (pos, &stamp) in f.token_stamps_ns.iter().enumerate().skip(1) {
                        let span = if spans[pos].symbol == TruthSymbol::Null {
                            spans[pos]
                        } else {
                            spans[pos + 1]
                        };
                        assert!(
                            (span.start_ns..span.end_ns).contains(&stamp),
                            "{name} {} offer {k} token {pos} at {stamp} outside {span:?}",
                            o.name
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn offer_start_to_final_null_is_about_the_papers_95_6_s() {
    let s = paper_broadcast(5 * NS_PER_S, &[0b011010, 0b100111], false).unwrap();
    let r = run(&s, 3, SegmenterConfig::rgb(), 0);
    for i in 0..3 {
        let o = r.output(i).unwrap();
        for (offer, frame) in s.offers().iter().zip(&o.frames) {
            let interval_s = (frame.final_null_ns() - offer.start_ns) as f64 * 1e-9;
            println!(
                "{} offer {:06b}: offer start to final NULL {interval_s:.2} s",
                o.name, offer.payload
            );
            assert!(
                (94.5..=96.5).contains(&interval_s),
                "{}: {interval_s} s",
                o.name
            );
        }
    }
}

#[test]
fn an_interruption_mid_frame_prevents_release_of_that_frame_only() {
    let payloads = [0b011010, 0b100111];
    let s = paper_broadcast(5 * NS_PER_S, &payloads, false).unwrap();
    // In the middle of offer 1's bit 3.
    let bit3 = s
        .timeline()
        .iter()
        .find(|sp| {
            sp.slot
                .is_some_and(|sl| sl.offer_index == 0 && sl.position == 7)
        })
        .unwrap();
    let cut_ns = (bit3.start_ns + bit3.end_ns) / 2 / PERIOD_NS * PERIOD_NS;
    let mut r = IdealReceiver::new(3, SegmenterConfig::rgb()).unwrap();
    r.run_setpoints(&s, 0, cut_ns + 1, PERIOD_NS).unwrap();
    // O2's receiver reports lost input right after its sample at `cut_ns`.
    r.interrupt(1, cut_ns).unwrap();
    r.run_setpoints(&s, cut_ns + PERIOD_NS, s.end_ns() + NS_PER_S, PERIOD_NS)
        .unwrap();
    assert_eq!(r.output(0).unwrap().payloads(), payloads.to_vec());
    assert_eq!(r.output(2).unwrap().payloads(), payloads.to_vec());
    let o2 = r.output(1).unwrap();
    assert_eq!(
        o2.payloads(),
        vec![payloads[1]],
        "O2 lost offer 1 only: {:?}",
        o2.tokens
    );
    let unknowns: Vec<_> = o2
        .tokens
        .iter()
        .filter(|t| t.token == Token::Unknown)
        .collect();
    assert_eq!(
        unknowns.len(),
        1,
        "one interruption token, then the motion is not a candidate"
    );
    assert_eq!(
        unknowns[0].cause,
        TokenCause::Interrupted(Interruption::External)
    );
}

#[test]
fn a_single_missing_camera_frame_mid_frame_prevents_release() {
    let s = paper_broadcast(5 * NS_PER_S, &[0b010000], false).unwrap();
    let null5 = s
        .timeline()
        .iter()
        .find(|sp| sp.slot.is_some_and(|sl| sl.position == 10))
        .unwrap();
    // Drop one 40 ms sample during a NULL hover: the rest timer must restart and the frame die.
    let dropped_ns = (null5.start_ns + NS_PER_S) / PERIOD_NS * PERIOD_NS;
    let mut r = IdealReceiver::new(3, SegmenterConfig::rgb()).unwrap();
    let mut t = 0;
    while t < s.end_ns() + NS_PER_S {
        if t != dropped_ns {
            r.push(t, s.setpoint_at(t)).unwrap();
        }
        t += PERIOD_NS;
    }
    for o in r.outputs() {
        assert!(o.frames.is_empty(), "{}: {:?}", o.name, o.payloads());
        assert!(o.tokens.iter().any(|t| matches!(
            t.cause,
            TokenCause::Interrupted(Interruption::Gap { gap_ns: 80_000_000 })
        )));
    }
}

#[test]
fn event_acquisition_preamble_gives_a_first_null_before_start() {
    // An event receiver cannot see a stationary target, so it starts seeing at the sweep.
    let config = GestureConfig::default();
    let s = broadcast(
        16 * NS_PER_S,
        &[0b011010],
        true,
        &config,
        proto::FrameCheck::None,
    )
    .unwrap();
    let sweep = s.timeline()[0];
    assert_eq!(sweep.symbol, TruthSymbol::Acquisition);
    let start_span = s.timeline()[2];
    assert_eq!(start_span.symbol, TruthSymbol::Action(Action::Start));
    let r = run(&s, 3, SegmenterConfig::events(), sweep.start_ns);
    for o in r.outputs() {
        let t = &o.tokens;
        // The sweep is seen without a delimiter before it, so it yields no symbol; the quiet
        // after it is the frame's first NULL, confirmed with ≥ 2 s to spare before START.
        assert_eq!(t[0].token, Token::Null, "{}: {t:?}", o.name);
        assert!(t[0].stamp_ns >= sweep.end_ns + 2 * NS_PER_S);
        assert!(
            t[0].stamp_ns + 2 * NS_PER_S <= start_span.start_ns,
            "{}: {t:?}",
            o.name
        );
        assert_eq!(o.payloads(), vec![0b011010], "{}", o.name);
        assert_eq!(o.frames[0].first_null_ns(), t[0].stamp_ns);
    }
    // The preamble costs only the sweep: the offer itself is laid out as without it.
    let plain = broadcast(
        16 * NS_PER_S,
        &[0b011010],
        false,
        &config,
        proto::FrameCheck::None,
    )
    .unwrap();
    assert_eq!(
        s.offers()[0].start_ns,
        plain.offers()[0].start_ns + config.acquisition.duration_ns
    );
    assert_eq!(
        s.end_ns() - s.offers()[0].start_ns,
        plain.end_ns() - plain.offers()[0].start_ns
    );
}

#[test]
fn ideal_receiver_is_deterministic() {
    let s = paper_broadcast(5 * NS_PER_S, &[0b011010, 0b100111], true).unwrap();
    let a = run(&s, 3, SegmenterConfig::events(), 0);
    let b = run(&s, 3, SegmenterConfig::events(), 0);
    assert_eq!(a.outputs(), b.outputs());
}
