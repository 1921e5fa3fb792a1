//! The fast converter is bit-identical to the scalar reference: random frames (proptest),
//! structured frames, the synthetic scene, and rendered frames when fixtures are present.

use std::path::Path;

use event_camera::reference::ReferenceConverter;
use event_camera::synthetic::MovingBlobScene;
use event_camera::{Converter, DEFAULT_THRESHOLD, Event};
use proptest::prelude::*;

/// Feeds `frames` to both converters and asserts identical events and levels after each.
/// Returns the total number of events.
fn assert_identical(width: u16, height: u16, threshold: f64, frames: &[(u64, Vec<u8>)]) -> usize {
    let mut fast = Converter::new(width, height, threshold).unwrap();
    let mut reference = ReferenceConverter::new(width, height, threshold).unwrap();
    let mut total = 0;
    for (k, (stamp_ns, rgb)) in frames.iter().enumerate() {
        let mut got: Vec<Event> = Vec::new();
        fast.push(*stamp_ns, rgb, &mut got).unwrap();
        let want = reference.push(*stamp_ns, rgb).unwrap();
        assert_eq!(got.len(), want.len(), "frame {k}: event count");
        assert_eq!(got, want, "frame {k}");
        total += got.len();
    }
    for y in 0..height {
        for x in 0..width {
            assert_eq!(
                fast.level(x, y),
                reference.level(x, y),
                "level at ({x}, {y})"
            );
        }
    }
    total
}

/// How frame k+1 is made from the frames so far.
#[derive(Debug, Clone)]
enum Step {
    /// Entirely new random content.
    Random(Vec<u8>),
    /// The previous frame with some bytes replaced.
    Edit(Vec<(usize, u8)>),
    /// An exact copy of an earlier frame (index modulo the count so far): exact returns.
    Repeat(usize),
    /// The previous frame scaled by num/64 (global brightness change, many events per pixel).
    Scale(u16),
}

fn frames_strategy() -> impl Strategy<Value = (u16, u16, f64, Vec<(u64, Vec<u8>)>)> {
    (1u16..=45, 1u16..=9)
        .prop_flat_map(|(w, h)| {
            let bytes = usize::from(w) * usize::from(h) * 3;
            let step = prop_oneof![
                prop::collection::vec(any::<u8>(), bytes).prop_map(Step::Random),
                prop::collection::vec((0..bytes, any::<u8>()), 0..12).prop_map(Step::Edit),
                any::<usize>().prop_map(Step::Repeat),
                (0u16..=160).prop_map(Step::Scale),
            ];
            (
                Just(w),
                Just(h),
                prop_oneof![Just(DEFAULT_THRESHOLD), 0.01f64..1.5],
                prop::collection::vec(any::<u8>(), bytes),
                prop::collection::vec((1u64..=50_000_000, step), 1..10),
            )
        })
        .prop_map(|(w, h, threshold, first, steps)| {
            let mut frames = vec![(7u64, first)];
            for (dt_ns, step) in steps {
                let prev = &frames.last().unwrap().1;
                let next = match step {
                    Step::Random(rgb) => rgb,
                    Step::Edit(edits) => {
                        let mut rgb = prev.clone();
                        for (i, v) in edits {
                            rgb[i] = v;
                        }
                        rgb
                    }
                    Step::Repeat(i) => frames[i % frames.len()].1.clone(),
                    Step::Scale(num) => prev
                        .iter()
                        .map(|&v| (u32::from(v) * u32::from(num) / 64).min(255) as u8)
                        .collect(),
                };
                let stamp_ns = frames.last().unwrap().0 + dt_ns;
                frames.push((stamp_ns, next));
            }
            (w, h, threshold, frames)
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]
    #[test]
    fn fast_matches_reference_on_random_frames((w, h, threshold, frames) in frames_strategy()) {
        assert_identical(w, h, threshold, &frames);
    }
}

#[test]
fn fast_matches_reference_on_structured_frames() {
    // Every gray level and every primary ramp, up and down, on a 256×4 strip, plus exact
    // returns, a whole-frame black/white flash and odd interval lengths.
    let (w, h) = (256u16, 4u16);
    let frame = |f: &dyn Fn(usize, usize) -> [u8; 3]| -> Vec<u8> {
        (0..usize::from(h))
            .flat_map(|y| (0..usize::from(w)).flat_map(move |x| f(x, y)))
            .collect()
    };
    let ramp = |shift: usize| {
        frame(&|x, y| {
            let v = ((x + shift) % 256) as u8;
            match y {
                0 => [v, v, v],
                1 => [v, 0, 0],
                2 => [0, v, 0],
                _ => [0, 0, v],
            }
        })
    };
    let mut frames = Vec::new();
    let mut t = 0;
    for (k, rgb) in [
        ramp(0),
        ramp(1),
        ramp(9),
        ramp(0),
        frame(&|_, _| [255; 3]),
        frame(&|_, _| [0; 3]),
        ramp(0),
        ramp(128),
        ramp(0),
        ramp(255),
        ramp(3),
    ]
    .into_iter()
    .enumerate()
    {
        t += 1 + 3_333_333 * k as u64;
        frames.push((t, rgb));
    }
    let total = assert_identical(w, h, DEFAULT_THRESHOLD, &frames);
    assert!(
        total > 10_000,
        "structured frames must exercise many crossings ({total})"
    );
}

#[test]
fn fast_matches_reference_on_the_synthetic_scene() {
    let (w, h) = (640u16, 480u16);
    let scene = MovingBlobScene::new(w, h);
    let frames: Vec<(u64, Vec<u8>)> = (0..25u64)
        .map(|k| (k * 10_000_000, scene.frame(k * 10_000_000)))
        .collect();
    let total = assert_identical(w, h, DEFAULT_THRESHOLD, &frames);
    assert!(
        total > 1_000,
        "the moving blob must produce events ({total})"
    );
}

#[test]
fn fast_matches_reference_on_rendered_frames_when_present() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/frames");
    let Ok(entries) = std::fs::read_dir(&dir) else {
        eprintln!(
            "no rendered fixtures in {}; covered by synthetic frames",
            dir.display()
        );
        return;
    };
    let mut paths: Vec<_> = entries
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")))
        .collect();
    paths.sort();
    let mut frames = Vec::new();
    let mut size = None;
    for (k, path) in paths.iter().enumerate() {
        let image = event_camera::picture::decode_png(&std::fs::read(path).unwrap())
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let dims = (image.width() as u16, image.height() as u16);
        assert_eq!(
            *size.get_or_insert(dims),
            dims,
            "{}: size differs",
            path.display()
        );
        frames.push((k as u64 * 10_000_000, image.into_raw()));
    }
    if let Some((w, h)) = size {
        let total = assert_identical(w, h, DEFAULT_THRESHOLD, &frames);
        eprintln!(
            "{} rendered frames, {total} events, identical",
            frames.len()
        );
    }
}
