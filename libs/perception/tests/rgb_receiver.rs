//! The RGB receiver on synthetic frames (no MuJoCo): a textured 48 × 12 px drone drawn with exact
//! area coverage, flown along each action's keypoint path at 25 Hz with 4.5 s NULL rests.

#[path = "support/rgb_scene.rs"]
mod rgb_scene;

use image::GrayImage;
use perception::rgb::features::{FeatureConfig, FeatureDetector, Region};
use perception::rgb::klt::{Klt, KltConfig};
use perception::rgb::{
    FrameRejection, RgbInterruptCause, RgbReceiver, RgbReceiverConfig, TrackEvent,
};
use proto::frame::frame_tokens;
use proto::{Action, RgbFrame, Token};
use proto::{Decoder, Interruption, Sample, SegmentToken, SegmenterConfig, TokenCause};
use rgb_scene::{Backdrop, Flight, HOVER_PX, PERIOD_NS, REST_NS, Scene, frame};

fn grey(rgb: &[u8]) -> GrayImage {
    let (w, h) = (u32::from(rgb_scene::WIDTH), u32::from(rgb_scene::HEIGHT));
    GrayImage::from_fn(w, h, |x, y| {
        let i = ((y * w + x) * 3) as usize;
        image::Luma([perception::rgb::luma::luma(rgb[i], rgb[i + 1], rgb[i + 2])])
    })
}

/// Feeds every frame of `flight` (except the indices in `skip`) and returns the receiver.
fn fly(scene: &Scene, flight: &Flight, skip: &[usize]) -> RgbReceiver {
    let mut rx = RgbReceiver::paper();
    for (k, p) in flight.points_px.iter().enumerate() {
        if !skip.contains(&k) {
            rx.push_frame(&frame(k as u64, scene.render(Some(*p))));
        }
    }
    rx
}

/// The ideal receiver of the same flight: the drone's true image positions through the same
/// segmenter and parser.
fn ideal_tokens(flight: &Flight) -> Vec<SegmentToken> {
    let mut d = Decoder::new(SegmenterConfig::rgb()).unwrap();
    let mut out = Vec::new();
    for (k, p) in flight.points_px.iter().enumerate() {
        out.extend(
            d.push(Sample::tracked((k as u64 + 1) * PERIOD_NS, *p))
                .unwrap()
                .tokens,
        );
    }
    out
}

fn labels(tokens: &[SegmentToken]) -> Vec<Token> {
    tokens.iter().map(|t| t.token).collect()
}

/// Shi–Tomasi features on the drone drawn at `base`.
fn drone_features(frame: &GrayImage, base: [f64; 2]) -> Vec<[f32; 2]> {
    let region = Region::around(base, [32.0, 12.0], 640, 480).unwrap();
    FeatureDetector::new()
        .detect(frame, region, &[], 40, &FeatureConfig::paper())
        .iter()
        .map(|f| f.point_px)
        .collect()
}

#[test]
fn klt_recovers_known_subpixel_translations() {
    let scene = Scene::new(Backdrop::Wall);
    let base = [HOVER_PX[0] + 0.13, HOVER_PX[1] + 0.29];
    let first = grey(&scene.render(Some(base)));
    let points = drone_features(&first, base);
    assert!(
        points.len() >= 10,
        "only {} features on the drone",
        points.len()
    );
    for shift in [
        [0.25, 0.0],
        [0.0, 0.4],
        [0.37, -0.21],
        [1.5, 0.75],
        [-2.6, 1.3],
        [5.25, -3.75],
    ] {
        let moved = grey(&scene.render(Some([base[0] + shift[0], base[1] + shift[1]])));
        let mut klt = Klt::new(KltConfig::paper()).unwrap();
        klt.advance(&first);
        klt.advance(&moved);
        let mut out = Vec::new();
        klt.track(&points, None, &mut out);
        let mut d: Vec<[f64; 2]> = points
            .iter()
            .zip(&out)
            .filter_map(|(p, n)| n.map(|n| [f64::from(n[0] - p[0]), f64::from(n[1] - p[1])]))
            .collect();
        assert!(
            d.len() >= 8,
            "shift {shift:?}: only {} points tracked",
            d.len()
        );
        for axis in 0..2 {
            d.sort_by(|a, b| a[axis].total_cmp(&b[axis]));
            let median = d[d.len() / 2][axis];
            assert!(
                (median - shift[axis]).abs() <= 0.1,
                "shift {shift:?}: median displacement {median:.3} on axis {axis}"
            );
        }
    }
}

/// A camera that turned between two frames moves everything in the image, here by 52 px: more
/// than the pyramid reaches from where the points were, easy from where the turn predicts them
/// (the prediction off by 2 px, the target's own motion).
#[test]
fn klt_seeded_with_the_cameras_turn_tracks_beyond_its_reach() {
    let scene = Scene::new(Backdrop::Wall);
    let base = HOVER_PX;
    let first = grey(&scene.render(Some(base)));
    let (dx, dy) = (52i64, -20i64);
    let moved = GrayImage::from_fn(first.width(), first.height(), |x, y| {
        let (sx, sy) = (i64::from(x) - dx, i64::from(y) - dy);
        if sx >= 0 && sy >= 0 && sx < i64::from(first.width()) && sy < i64::from(first.height()) {
            *first.get_pixel(sx as u32, sy as u32)
        } else {
            image::Luma([0])
        }
    });
    let points = drone_features(&first, base);
    let correct = |out: &[Option<[f32; 2]>]| {
        points
            .iter()
            .zip(out)
            .filter(|(p, n)| {
                n.is_some_and(|n| {
                    (f64::from(n[0] - p[0]) - dx as f64).abs() < 0.1
                        && (f64::from(n[1] - p[1]) - dy as f64).abs() < 0.1
                })
            })
            .count()
    };
    let mut klt = Klt::new(KltConfig::paper()).unwrap();
    klt.advance(&first);
    klt.advance(&moved);
    let mut out = Vec::new();
    klt.track(&points, None, &mut out);
    let unseeded = correct(&out);
    let predicted: Vec<[f32; 2]> = points
        .iter()
        .map(|p| [p[0] + dx as f32 - 2.0, p[1] + dy as f32 + 1.5])
        .collect();
    klt.track(&points, Some(&predicted), &mut out);
    let seeded = correct(&out);
    assert!(
        seeded * 10 >= points.len() * 9,
        "seeded: {seeded} of {}",
        points.len()
    );
    assert!(
        unseeded * 2 < points.len(),
        "unseeded: {unseeded} of {}",
        points.len()
    );
}

#[test]
fn the_trajectory_follows_every_action_to_a_fraction_of_a_pixel() {
    let scene = Scene::new(Backdrop::Wall);
    for action in Action::ALL {
        let mut flight = Flight::default();
        flight
            .rest(1_000_000_000)
            .action(action)
            .rest(1_000_000_000);
        let mut rx = RgbReceiver::paper();
        let mut offset = None;
        let mut worst: f64 = 0.0;
        for (k, p) in flight.points_px.iter().enumerate() {
            let out = rx.push_frame(&frame(k as u64, scene.render(Some(*p))));
            let track = out.track.expect("every frame is tracked");
            assert!(track.reliable, "{action:?} frame {k}: {track:?}");
            let q = track.point_px.unwrap();
            let o = *offset.get_or_insert([q[0] - p[0], q[1] - p[1]]);
            worst = worst.max((q[0] - o[0] - p[0]).hypot(q[1] - o[1] - p[1]));
        }
        assert_eq!(
            rx.interruptions().len(),
            0,
            "{action:?}: {:?}",
            rx.interruptions()
        );
        // 69–80 px excursions; the integrated KLT path stays within a fraction of a pixel.
        assert!(worst <= 0.5, "{action:?}: trajectory off by {worst:.3} px");
    }
}

#[test]
fn a_full_synthetic_frame_releases_exactly_its_payload_at_ideal_token_times() {
    // The room backdrop puts the floor corner right under bit 0's apex: static corners must not
    // capture the tracker.
    let scene = Scene::new(Backdrop::Room);
    let payload = 0b011010;
    let mut flight = Flight::default();
    flight.offer(payload);
    let rx = fly(&scene, &flight, &[]);
    let released: Vec<u8> = rx.frames().iter().map(|f| f.payload).collect();
    assert_eq!(released, [payload]);
    assert_eq!(labels(rx.tokens()), frame_tokens(payload).to_vec());
    let ideal = ideal_tokens(&flight);
    assert_eq!(labels(&ideal), labels(rx.tokens()));
    for (ours, theirs) in rx.tokens().iter().zip(&ideal) {
        let off_ns = ours.stamp_ns.abs_diff(theirs.stamp_ns);
        assert!(
            off_ns <= 200_000_000,
            "{ours:?} is {off_ns} ns from the ideal {theirs:?}"
        );
    }
    assert_eq!(
        rx.frames()[0].token_stamps_ns,
        rx.tokens().iter().map(|t| t.stamp_ns).collect::<Vec<_>>()
    );
    // One trajectory per decoded action, each spanning its motion.
    let trajectories = rx.trajectories();
    assert_eq!(trajectories.len(), 8);
    assert!(
        trajectories
            .iter()
            .all(|t| t.samples.len() >= 150 && t.samples.iter().all(|s| s.reliable))
    );
}

#[test]
fn a_receiver_without_history_reports_the_same_outcomes_and_keeps_none() {
    let scene = Scene::new(Backdrop::Room);
    let mut flight = Flight::default();
    flight.offer(0b010011);
    let mut kept = RgbReceiver::paper();
    let mut forgetting = RgbReceiver::paper().without_history();
    for (k, p) in flight.points_px.iter().enumerate() {
        let f = frame(k as u64, scene.render(Some(*p)));
        assert_eq!(kept.push_frame(&f), forgetting.push_frame(&f), "frame {k}");
    }
    assert_eq!(kept.frames().len(), 1);
    assert!(forgetting.tokens().is_empty() && forgetting.frames().is_empty());
    assert!(forgetting.trajectories().is_empty());
}

#[test]
fn a_sequence_gap_mid_symbol_invalidates_the_frame_and_the_next_offer_still_decodes() {
    let scene = Scene::new(Backdrop::Wall);
    let (first, second) = (0b011010, 0b100111);
    let mut flight = Flight::default();
    flight.offer(first);
    let first_len = flight.len();
    flight.offer(second);
    // The middle of the third bit's motion: after NULL START NULL b1 NULL b2 NULL.
    let third_bit = flight.rest_starts[3] + (REST_NS / PERIOD_NS) as usize + 75;
    assert!(third_bit < first_len);
    let rx = fly(&scene, &flight, &[third_bit, third_bit + 1, third_bit + 2]);
    let released: Vec<u8> = rx.frames().iter().map(|f| f.payload).collect();
    assert_eq!(
        released,
        [second],
        "the interrupted frame must not be released"
    );
    assert_eq!(
        rx.interruptions().get(&RgbInterruptCause::SequenceGap),
        Some(&1)
    );
    let unknown = rx
        .tokens()
        .iter()
        .find(|t| t.token == Token::Unknown)
        .expect("an Unknown token");
    assert!(matches!(
        unknown.cause,
        TokenCause::Interrupted(Interruption::External)
    ));
    assert_eq!(unknown.stamp_ns, (third_bit as u64 + 4) * PERIOD_NS);
}

#[test]
fn continuity_flags_interrupt_the_symbol_in_progress() {
    let scene = Scene::new(Backdrop::Wall);
    let mut flight = Flight::default();
    flight.rest(REST_NS).action(Action::Start).rest(REST_NS);
    let mid = flight.rest_starts[1] - 100;
    for (flag, cause) in [
        (None, None),
        (Some("continuous"), Some(RgbInterruptCause::NotContinuous)),
        (Some("valid"), Some(RgbInterruptCause::Invalid)),
    ] {
        let mut rx = RgbReceiver::paper();
        for (k, p) in flight.points_px.iter().enumerate() {
            let mut f = frame(k as u64, scene.render(Some(*p)));
            if k == mid {
                match flag {
                    Some("continuous") => f.continuous = false,
                    Some("valid") => f.valid = false,
                    _ => {}
                }
            }
            rx.push_frame(&f);
        }
        let want = if cause.is_some() {
            vec![Token::Null, Token::Unknown, Token::Null]
        } else {
            vec![Token::Null, Token::Start, Token::Null]
        };
        assert_eq!(labels(rx.tokens()), want, "{flag:?}");
        assert_eq!(
            rx.interruptions().keys().copied().collect::<Vec<_>>(),
            cause.into_iter().collect::<Vec<_>>()
        );
    }
}

#[test]
fn black_and_blank_frames_never_yield_a_trajectory_or_a_frame() {
    let mut flight = Flight::default();
    flight.offer(0b010000);
    for backdrop in [Backdrop::Black, Backdrop::Wall] {
        // Black: the drone flies but the camera is blacked out. Wall: an empty, blank view.
        let scene = Scene::new(backdrop);
        let mut rx = RgbReceiver::paper();
        for (k, p) in flight.points_px.iter().enumerate() {
            let rgb = if backdrop == Backdrop::Black {
                scene.render(Some(*p))
            } else {
                scene.render(None)
            };
            let out = rx.push_frame(&frame(k as u64, rgb));
            let track = out.track.unwrap();
            assert_eq!(track.point_px, None, "{backdrop:?} frame {k}");
            assert_eq!(track.event, TrackEvent::Searching);
        }
        assert!(rx.frames().is_empty(), "{backdrop:?}");
        // At most one interruption token, never a NULL.
        assert_eq!(labels(rx.tokens()), [Token::Unknown], "{backdrop:?}");
        assert!(rx.trajectories().is_empty());
    }
}

#[test]
fn a_vanishing_target_interrupts_and_is_reacquired() {
    let scene = Scene::new(Backdrop::Wall);
    let mut rx = RgbReceiver::paper();
    let mut k = 0u64;
    let mut push = |rx: &mut RgbReceiver, drone: bool| {
        let out = rx.push_frame(&frame(k, scene.render(drone.then_some(HOVER_PX))));
        k += 1;
        out
    };
    for _ in 0..100 {
        push(&mut rx, true);
    }
    assert_eq!(labels(rx.tokens()), [Token::Null]);
    let out = push(&mut rx, false);
    assert!(matches!(out.track.unwrap().event, TrackEvent::Lost(_)));
    assert_eq!(out.interruption, Some(RgbInterruptCause::TrackingLost));
    assert_eq!(labels(&out.step.tokens), [Token::Unknown]);
    assert_eq!(
        push(&mut rx, true).track.unwrap().event,
        TrackEvent::Acquired
    );
    for _ in 0..80 {
        push(&mut rx, true);
    }
    assert_eq!(
        labels(rx.tokens()),
        [Token::Null, Token::Unknown, Token::Null]
    );
}

#[test]
fn malformed_and_out_of_order_frames_are_rejected_and_interrupt() {
    let scene = Scene::new(Backdrop::Wall);
    let mut rx = RgbReceiver::paper();
    for k in 0..100 {
        rx.push_frame(&frame(k, scene.render(Some(HOVER_PX))));
    }
    assert_eq!(labels(rx.tokens()), [Token::Null]);
    let mut short = frame(100, scene.render(Some(HOVER_PX)));
    short.rgb.pop();
    let out = rx.push_frame(&short);
    assert_eq!(out.rejected, Some(FrameRejection::BadSize));
    assert_eq!(labels(&out.step.tokens), [Token::Unknown]);
    let tiny = RgbFrame {
        width: 8,
        height: 8,
        rgb: vec![0; 8 * 8 * 3],
        ..frame(101, Vec::new())
    };
    assert_eq!(
        rx.push_frame(&tiny).rejected,
        Some(FrameRejection::TooSmall)
    );
    rx.push_frame(&frame(102, scene.render(Some(HOVER_PX))));
    let stale = frame(50, scene.render(Some(HOVER_PX)));
    assert_eq!(
        rx.push_frame(&stale).rejected,
        Some(FrameRejection::StampNotIncreasing)
    );
    // A camera restart (sequence numbers and stamps start over later) is a discontinuity.
    let restarted = RgbFrame {
        stamp_ns: 200 * PERIOD_NS,
        ..frame(0, scene.render(Some(HOVER_PX)))
    };
    assert_eq!(
        rx.push_frame(&restarted).interruption,
        Some(RgbInterruptCause::Restart)
    );
    assert_eq!(rx.segmenter_errors(), 0);
}

#[test]
fn an_external_interruption_drops_the_incomplete_frame() {
    let scene = Scene::new(Backdrop::Wall);
    let payload = 0b100111;
    let mut flight = Flight::default();
    flight.offer(payload);
    let cut = flight.rest_starts[5] + 10;
    let mut rx = RgbReceiver::paper();
    for (k, p) in flight.points_px.iter().enumerate() {
        let f = frame(k as u64, scene.render(Some(*p)));
        if k == cut {
            let out = rx.interrupt(f.stamp_ns - 1);
            assert_eq!(labels(&out.step.tokens), [Token::Unknown]);
        }
        rx.push_frame(&f);
    }
    assert!(rx.frames().is_empty());
    assert_eq!(
        rx.interruptions().get(&RgbInterruptCause::External),
        Some(&1)
    );
}

#[test]
fn settings_are_validated() {
    let mut c = RgbReceiverConfig::paper();
    c.klt.window_px = 20;
    assert!(RgbReceiver::new(c).is_err());
    let mut c = RgbReceiverConfig::paper();
    c.tracker.min_tracked_features = 0;
    assert!(RgbReceiver::new(c).is_err());
    let mut c = RgbReceiverConfig::paper();
    c.features.min_score = f32::NAN;
    assert!(RgbReceiver::new(c).is_err());
    let mut c = RgbReceiverConfig::paper();
    c.segmenter.anchor_radius_px = 0.0;
    assert!(RgbReceiver::new(c).is_err());
    assert!(RgbReceiver::new(RgbReceiverConfig::paper()).is_ok());
}
