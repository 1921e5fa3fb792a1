//! The converter rules on one or two pixels, checked on both the fast and the reference
//! implementation.

use event_camera::reference::ReferenceConverter;
use event_camera::{ConvertError, Converter, DEFAULT_THRESHOLD, Event, Polarity};

const DT_NS: u64 = 10_000_000;
const C: f64 = DEFAULT_THRESHOLD;

/// Both implementations behind one interface so every rule is checked on each.
trait Conv {
    fn push(&mut self, stamp_ns: u64, rgb: &[u8]) -> Result<Vec<Event>, ConvertError>;
    fn level(&self, x: u16, y: u16) -> i32;
}

impl Conv for Converter {
    fn push(&mut self, stamp_ns: u64, rgb: &[u8]) -> Result<Vec<Event>, ConvertError> {
        let mut out = Vec::new();
        Converter::push(self, stamp_ns, rgb, &mut out)?;
        Ok(out)
    }
    fn level(&self, x: u16, y: u16) -> i32 {
        Converter::level(self, x, y)
    }
}

impl Conv for ReferenceConverter {
    fn push(&mut self, stamp_ns: u64, rgb: &[u8]) -> Result<Vec<Event>, ConvertError> {
        ReferenceConverter::push(self, stamp_ns, rgb)
    }
    fn level(&self, x: u16, y: u16) -> i32 {
        ReferenceConverter::level(self, x, y)
    }
}

fn both(width: u16, height: u16, threshold: f64) -> Vec<(&'static str, Box<dyn Conv>)> {
    vec![
        (
            "fast",
            Box::new(Converter::new(width, height, threshold).unwrap()),
        ),
        (
            "reference",
            Box::new(ReferenceConverter::new(width, height, threshold).unwrap()),
        ),
    ]
}

/// Gray value g gives Y = g exactly, so L = ln g.
fn gray(g: u8) -> Vec<u8> {
    vec![g; 3]
}

fn ln(g: u8) -> f64 {
    f64::from(g).ln()
}

/// The specified crossing time of `level_value` between d0 and d1 over (t0, t0 + DT_NS].
fn crossing(t0: u64, level_value: f64, d0: f64, d1: f64) -> u64 {
    t0 + ((level_value - d0) / (d1 - d0) * DT_NS as f64).ceil() as u64
}

#[test]
fn ramp_up_by_half_emits_two_on_events_at_interpolated_times() {
    // 100 → 165: ΔL = ln 1.65 = 0.5008, crossing 0.18 and 0.36 but not 0.54.
    for (name, mut conv) in both(1, 1, C) {
        assert!(
            conv.push(0, &gray(100)).unwrap().is_empty(),
            "{name}: first frame"
        );
        let events = conv.push(DT_NS, &gray(165)).unwrap();
        let d1 = ln(165) - ln(100);
        assert!((d1 - 0.5).abs() < 1e-3);
        let want: Vec<Event> = [C, 2.0 * C]
            .iter()
            .map(|&level| Event {
                t_ns: crossing(0, level, 0.0, d1),
                x: 0,
                y: 0,
                polarity: Polarity::On,
            })
            .collect();
        assert_eq!(events, want, "{name}");
        // Linear interpolation in log intensity: 0.18 / 0.5008 of the interval, and twice that.
        let ideal = |level: f64| level / d1 * DT_NS as f64;
        assert!(
            (events[0].t_ns as f64 - ideal(C)).abs() <= 1.0,
            "{name}: {events:?}"
        );
        assert!(
            (events[1].t_ns as f64 - ideal(2.0 * C)).abs() <= 1.0,
            "{name}: {events:?}"
        );
        assert_eq!(events[0].t_ns, 3_594_427, "{name}"); // ceil(1e7 · 0.18 / ln 1.65)
        assert_eq!(conv.level(0, 0), 2, "{name}");
    }
}

#[test]
fn ramp_down_emits_off_events() {
    for (name, mut conv) in both(1, 1, C) {
        conv.push(0, &gray(165)).unwrap();
        let events = conv.push(DT_NS, &gray(100)).unwrap();
        let d1 = ln(100) - ln(165);
        let want: Vec<Event> = [-C, -2.0 * C]
            .iter()
            .map(|&level| Event {
                t_ns: crossing(0, level, 0.0, d1),
                x: 0,
                y: 0,
                polarity: Polarity::Off,
            })
            .collect();
        assert_eq!(events, want, "{name}");
        assert_eq!(conv.level(0, 0), -2, "{name}");
    }
}

#[test]
fn residual_carries_into_the_next_interval() {
    for (name, mut conv) in both(1, 1, C) {
        conv.push(0, &gray(100)).unwrap();
        assert_eq!(conv.push(DT_NS, &gray(165)).unwrap().len(), 2, "{name}");
        // 165 → 172 is only ln(172/165) = 0.042 by itself, but the residual 0.5008 − 0.36
        // carries: 172 is ln 1.72 = 0.5423 above the start, past the third level 0.54.
        let events = conv.push(2 * DT_NS, &gray(172)).unwrap();
        let (d0, d1) = (ln(165) - ln(100), ln(172) - ln(100));
        assert_eq!(
            events,
            vec![Event {
                t_ns: crossing(DT_NS, 3.0 * C, d0, d1),
                x: 0,
                y: 0,
                polarity: Polarity::On
            }],
            "{name}"
        );
        assert!(
            events[0].t_ns > DT_NS + DT_NS * 9 / 10,
            "{name}: late in the interval"
        );
    }
    // Control: the same step from a fresh reference emits nothing.
    for (name, mut conv) in both(1, 1, C) {
        conv.push(0, &gray(165)).unwrap();
        assert!(conv.push(DT_NS, &gray(172)).unwrap().is_empty(), "{name}");
    }
}

#[test]
fn large_step_emits_every_crossing_in_time_order() {
    // Black to white: ln 255 = 5.54 spans 30 levels of 0.18.
    for (name, mut conv) in both(1, 1, C) {
        conv.push(0, &gray(0)).unwrap();
        let events = conv.push(DT_NS, &gray(255)).unwrap();
        assert_eq!(events.len(), 30, "{name}");
        assert!(events.iter().all(|e| e.polarity == Polarity::On));
        assert!(events.windows(2).all(|w| w[0].t_ns < w[1].t_ns), "{name}");
        assert!(
            events.iter().all(|e| e.t_ns > 0 && e.t_ns <= DT_NS),
            "{name}"
        );
        assert_eq!(conv.level(0, 0), 30);
        let back = conv.push(2 * DT_NS, &gray(0)).unwrap();
        assert_eq!(back.len(), 30, "{name}");
        assert!(back.iter().all(|e| e.polarity == Polarity::Off));
        assert_eq!(conv.level(0, 0), 0, "{name}");
    }
}

#[test]
fn returning_exactly_to_a_former_value_returns_to_the_same_level() {
    // 100 ↔ 130 (ΔL = 0.262): one ON up, and on the way back d = 0 exactly, which must fire the
    // OFF event because the comparison d ≤ (n−1)·C = 0 is inclusive.
    for (name, mut conv) in both(1, 1, C) {
        conv.push(0, &gray(100)).unwrap();
        for cycle in 0..50u64 {
            let up = conv.push((2 * cycle + 1) * DT_NS, &gray(130)).unwrap();
            assert_eq!(up.len(), 1, "{name} cycle {cycle}");
            assert_eq!(up[0].polarity, Polarity::On);
            assert_eq!(conv.level(0, 0), 1);
            let down = conv.push((2 * cycle + 2) * DT_NS, &gray(100)).unwrap();
            assert_eq!(down.len(), 1, "{name} cycle {cycle}");
            assert_eq!(down[0].polarity, Polarity::Off);
            // Crossing level 0 exactly at the end of the interval.
            assert_eq!(down[0].t_ns, (2 * cycle + 2) * DT_NS);
            assert_eq!(conv.level(0, 0), 0, "{name} cycle {cycle}");
        }
    }
}

/// Event counts per frame of the rejected design: a float reference accumulated by ±C.
fn naive_float_counts(values: &[u8]) -> Vec<usize> {
    let mut l_ref = ln(values[0]);
    let mut counts = Vec::new();
    for &v in &values[1..] {
        let (l, mut n) = (ln(v), 0);
        while l - l_ref >= C {
            l_ref += C;
            n += 1;
        }
        while l - l_ref <= -C {
            l_ref -= C;
            n += 1;
        }
        counts.push(n);
    }
    counts
}

#[test]
fn integer_levels_do_not_drift_where_float_accumulation_would() {
    // Gray pairs a < b two or more levels apart, alternated: with integer levels every return
    // to a value lands on the same level, so each frame emits the same number of events. Find
    // the pairs where an accumulated float reference lets rounding change a count, and check
    // both implementations are immune there.
    let mut discriminating = 0;
    for a in 1u8..=200 {
        for b in a + 1..=255 {
            let levels = ((ln(b) - ln(a)) / C).floor() as usize;
            if levels < 2 {
                continue;
            }
            let values: Vec<u8> = (0..9).map(|i| if i % 2 == 0 { a } else { b }).collect();
            let naive = naive_float_counts(&values);
            let first = naive[0];
            if naive.iter().all(|&n| n == first) {
                continue;
            }
            discriminating += 1;
            for (name, mut conv) in both(1, 1, C) {
                let mut counts = Vec::new();
                for (i, &v) in values.iter().enumerate() {
                    let events = conv.push(i as u64 * DT_NS, &gray(v)).unwrap();
                    if i > 0 {
                        counts.push(events.len());
                    }
                    assert_eq!(
                        conv.level(0, 0),
                        if i % 2 == 0 { 0 } else { counts[0] as i32 }
                    );
                }
                assert!(
                    counts.iter().all(|&n| n == counts[0]),
                    "{name} a={a} b={b}: {counts:?}"
                );
            }
        }
    }
    println!("{discriminating} discriminating pairs");
    assert!(
        discriminating > 0,
        "no pair where float accumulation drifts; test would not discriminate"
    );
}

#[test]
fn first_frame_and_static_scene_emit_nothing() {
    let (w, h) = (64u16, 48u16);
    let scene = event_camera::synthetic::MovingBlobScene::new(w, h);
    let frame = scene.frame(123_000_000);
    for (name, mut conv) in both(w, h, C) {
        assert!(
            conv.push(5, &frame).unwrap().is_empty(),
            "{name}: first frame"
        );
        for k in 1..20 {
            assert!(
                conv.push(5 + k * DT_NS, &frame).unwrap().is_empty(),
                "{name}: frame {k}"
            );
        }
        // The first frame is only a reference even when it differs wildly from the next.
        let mut conv2 = Converter::new(w, h, C).unwrap();
        let mut out = Vec::new();
        conv2.push(0, &vec![0; frame.len()], &mut out).unwrap();
        assert!(out.is_empty());
        conv2.push(DT_NS, &frame, &mut out).unwrap();
        assert!(
            !out.is_empty(),
            "{name}: a change after the first frame must emit"
        );
    }
}

#[test]
fn events_are_sorted_by_time_then_pixel_index() {
    // Pixels 0..4 of a 4×1 strip: pixels 1 and 3 make the same step (same times), pixel 2 a
    // larger one (earlier first crossing), pixel 0 stays.
    for (name, mut conv) in both(4, 1, C) {
        conv.push(0, &[100; 12]).unwrap();
        let next = [[100; 3], [165; 3], [255; 3], [165; 3]].concat();
        let events = conv.push(DT_NS, &next).unwrap();
        let key: Vec<(u64, u16)> = events.iter().map(|e| (e.t_ns, e.x)).collect();
        let mut sorted = key.clone();
        sorted.sort();
        assert_eq!(key, sorted, "{name}");
        assert_eq!(events.iter().filter(|e| e.x == 1).count(), 2);
        assert_eq!(events.iter().filter(|e| e.x == 3).count(), 2);
        assert_eq!(events.iter().filter(|e| e.x == 2).count(), 5); // ln 2.55 = 0.936
        assert!(events.iter().all(|e| e.x != 0));
        // Equal times: pixel 1 before pixel 3.
        let t13: Vec<u16> = events
            .iter()
            .filter(|e| e.t_ns == events.iter().find(|e| e.x == 1).unwrap().t_ns)
            .map(|e| e.x)
            .collect();
        assert_eq!(t13, vec![1, 3], "{name}");
        assert_eq!(events[0].x, 2, "{name}: the steepest pixel crosses first");
    }
}

#[test]
fn pixel_coordinates_are_row_major() {
    for (name, mut conv) in both(3, 2, C) {
        conv.push(0, &[50; 18]).unwrap();
        let mut next = vec![50; 18];
        next[3 * (3 + 2)..3 * (3 + 2) + 3].copy_from_slice(&[200; 3]); // x = 2, y = 1
        let events = conv.push(DT_NS, &next).unwrap();
        assert!(!events.is_empty());
        assert!(
            events.iter().all(|e| (e.x, e.y) == (2, 1)),
            "{name}: {events:?}"
        );
    }
}

#[test]
fn threshold_is_configurable() {
    for (name, mut conv) in both(1, 1, 0.1) {
        conv.push(0, &gray(100)).unwrap();
        assert_eq!(conv.push(DT_NS, &gray(165)).unwrap().len(), 5, "{name}"); // 0.5008 / 0.1
    }
}

#[test]
fn bad_configuration_and_frames_are_typed_errors_that_change_nothing() {
    for bad in [0.0, -0.18, f64::NAN, f64::INFINITY, 1e-4] {
        assert!(matches!(
            Converter::new(4, 4, bad),
            Err(ConvertError::BadThreshold(_))
        ));
        assert!(matches!(
            ReferenceConverter::new(4, 4, bad),
            Err(ConvertError::BadThreshold(_))
        ));
    }
    assert!(matches!(
        Converter::new(0, 4, C),
        Err(ConvertError::EmptySensor { .. })
    ));
    assert!(matches!(
        ReferenceConverter::new(4, 0, C),
        Err(ConvertError::EmptySensor { .. })
    ));
    for (name, mut conv) in both(1, 1, C) {
        assert!(matches!(
            conv.push(0, &[1, 2]),
            Err(ConvertError::FrameSize {
                got: 2,
                want: 3,
                ..
            })
        ));
        conv.push(DT_NS, &gray(100)).unwrap();
        assert_eq!(
            conv.push(DT_NS, &gray(200)),
            Err(ConvertError::StampNotIncreasing {
                stamp_ns: DT_NS,
                previous_ns: DT_NS
            }),
            "{name}"
        );
        assert!(conv.push(DT_NS - 1, &gray(200)).is_err());
        assert!(matches!(
            conv.push(2 * DT_NS, &[0; 6]),
            Err(ConvertError::FrameSize { .. })
        ));
        // The rejected frames left no trace: the next interval starts from the 100 frame.
        let events = conv.push(2 * DT_NS, &gray(165)).unwrap();
        assert_eq!(events.len(), 2, "{name}");
        assert_eq!(events[0].t_ns, DT_NS + 3_594_427, "{name}");
    }
}
