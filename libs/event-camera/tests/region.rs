//! Converting only the changed region gives exactly the packets of converting whole frames.

use event_camera::{CameraConfig, ConvertError, Converter, EventCamera};
use proptest::prelude::*;
use proto::{FrameChange, PixelRect};

const W: u16 = 40;
const H: u16 = 30;

/// One step: a rectangle repainted with a colour ramp (or nothing), the rectangle the caller
/// declares (the repainted one grown by `grow`, or the whole frame), and the black fault.
#[derive(Debug, Clone)]
struct Step {
    rect: Option<PixelRect>,
    base: u8,
    slope: u8,
    grow: u16,
    declare_all: bool,
    black: bool,
}

fn rect() -> impl Strategy<Value = PixelRect> {
    (0..W, 0..H).prop_flat_map(|(x, y)| {
        (1..=W - x, 1..=H - y).prop_map(move |(width, height)| PixelRect {
            x,
            y,
            width,
            height,
        })
    })
}

fn step() -> impl Strategy<Value = Step> {
    (
        prop::option::weighted(0.85, rect()),
        any::<u8>(),
        0u8..40,
        0u16..4,
        prop::bool::weighted(0.1),
        prop::bool::weighted(0.08),
    )
        .prop_map(|(rect, base, slope, grow, declare_all, black)| Step {
            rect,
            base,
            slope,
            grow,
            declare_all,
            black,
        })
}

fn paint(frame: &mut [u8], r: PixelRect, base: u8, slope: u8) {
    for y in r.y..r.y + r.height {
        for x in r.x..r.x + r.width {
            let i = 3 * (usize::from(y) * usize::from(W) + usize::from(x));
            let v = base.wrapping_add(slope.wrapping_mul((x + 2 * y) as u8));
            frame[i..i + 3].copy_from_slice(&[v, v.wrapping_mul(3), 255 - v]);
        }
    }
}

fn grown(r: PixelRect, by: u16) -> PixelRect {
    let x = r.x.saturating_sub(by);
    let y = r.y.saturating_sub(by);
    PixelRect {
        x,
        y,
        width: (r.x + r.width + by).min(W) - x,
        height: (r.y + r.height + by).min(H) - y,
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn region_pushes_equal_whole_frame_pushes(steps in prop::collection::vec(step(), 1..30)) {
        let config = CameraConfig {
            render_period_ns: 10_000_000,
            ..CameraConfig::paper(W, H)
        };
        let mut whole = EventCamera::new(config.clone()).unwrap();
        let mut region = EventCamera::new(config).unwrap();
        let mut frame = vec![90u8; 3 * usize::from(W) * usize::from(H)];
        let mut t = 10_000_000;
        let a = whole.push_frame(t, &frame).unwrap();
        let b = region.push_frame_change(t, &frame, FrameChange::All).unwrap();
        prop_assert_eq!(a, b);
        for s in &steps {
            t += 10_000_000;
            if let Some(r) = s.rect {
                paint(&mut frame, r, s.base, s.slope);
            }
            let change = match s.rect {
                _ if s.declare_all => FrameChange::All,
                Some(r) => FrameChange::Within(grown(r, s.grow)),
                None => FrameChange::Nothing,
            };
            whole.set_black_input(s.black);
            region.set_black_input(s.black);
            let a = whole.push_frame(t, &frame).unwrap();
            let b = region.push_frame_change(t, &frame, change).unwrap();
            prop_assert_eq!(a, b, "at {} ns after {:?}", t, s);
        }
    }
}

#[test]
fn a_region_outside_the_sensor_or_before_the_first_frame_is_refused() {
    let mut c = Converter::new(W, H, 0.2).unwrap();
    let frame = vec![0u8; 3 * usize::from(W) * usize::from(H)];
    let inside = PixelRect {
        x: 0,
        y: 0,
        width: 1,
        height: 1,
    };
    let mut out = Vec::new();
    assert_eq!(
        c.push_region(1, &frame, Some(inside), &mut out),
        Err(ConvertError::RegionBeforeFirstFrame)
    );
    c.push(1, &frame, &mut out).unwrap();
    let outside = PixelRect {
        x: W - 2,
        y: 0,
        width: 3,
        height: 1,
    };
    let err = c
        .push_region(2, &frame, Some(outside), &mut out)
        .unwrap_err();
    assert!(matches!(err, ConvertError::RegionOutside { .. }), "{err}");
    // Refused pushes change nothing: the next valid push still works at stamp 2.
    c.push_region(2, &frame, None, &mut out).unwrap();
    assert!(out.is_empty());
}
