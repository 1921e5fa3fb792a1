//! The fit against streams Waggle generates from known terms: each term recovered within 10 %.

use event_camera::fit::{Background, fit};
use event_camera::synthetic::MovingBlobScene;
use event_camera::{Event, EventNoise, NoisyConverter};

const RENDER_NS: u64 = 10_000_000;

/// `seconds` of a static grey scene through a sensor with `noise` (threshold 0.2).
fn static_stream(width: u16, height: u16, seconds: u64, noise: &EventNoise) -> Vec<Event> {
    let mut sensor = NoisyConverter::new(width, height, 0.2, noise).expect("sensor");
    let grey = vec![128u8; usize::from(width) * usize::from(height) * 3];
    let mut events = Vec::new();
    sensor.push(0, &grey, &mut events).expect("first frame");
    for k in 1..=seconds * 1_000_000_000 / RENDER_NS {
        sensor
            .push_region(k * RENDER_NS, &grey, None, &mut events)
            .expect("frame");
    }
    events
}

/// `seconds` of the moving-blob scene through a sensor with threshold `c` and `noise`.
fn moving_stream(width: u16, height: u16, seconds: u64, c: f64, noise: &EventNoise) -> Vec<Event> {
    let renders = MovingBlobScene::new(width, height).renders(seconds * 1_000_000_000, RENDER_NS);
    let mut sensor = NoisyConverter::new(width, height, c, noise).expect("sensor");
    let mut events = Vec::new();
    for (k, (rgb, _)) in renders.iter().enumerate() {
        sensor
            .push(k as u64 * RENDER_NS, rgb, &mut events)
            .expect("frame");
    }
    events
}

fn within(name: &str, got: f64, want: f64, tolerance: f64) {
    assert!(
        (got - want).abs() <= tolerance * want,
        "{name}: fitted {got}, generated with {want}"
    );
}

#[test]
fn a_static_stretch_recovers_shot_noise_leak_and_hot_pixels() {
    let noise = EventNoise {
        shot_noise_hz: 4.0,
        leak_hz: 0.5,
        hot_pixels: 12,
        hot_pixel_hz: 60.0,
        seed: 21,
        ..EventNoise::default()
    };
    let (w, h) = (160, 120);
    let events = static_stream(w, h, 20, &noise);
    let mut sensor = NoisyConverter::new(w, h, 0.2, &noise).expect("sensor");
    sensor
        .push(
            0,
            &vec![0; usize::from(w) * usize::from(h) * 3],
            &mut Vec::new(),
        )
        .expect("frame");
    let mut hot = sensor.hot_pixel_positions();
    hot.sort_unstable();
    for background in [
        Background::Static {
            start_ns: 2_000_000_000,
            end_ns: 18_000_000_000,
        },
        Background::Isolated,
    ] {
        let fitted = fit(&events, w, h, background).expect("fit");
        within("shot noise", fitted.shot_noise_hz, 4.0, 0.1);
        within("leak", fitted.leak_hz, 0.5, 0.1);
        assert_eq!(fitted.hot_pixels, hot, "{background:?}");
        within("hot pixel rate", fitted.hot_pixel_hz, 60.0, 0.1);
        let terms = fitted.terms();
        assert!(
            terms.windows(2).all(|p| p[0].0 < p[1].0),
            "sorted: {terms:?}"
        );
        assert!(terms.contains(&("events.hot_pixels", 12.0)));
    }
}

#[test]
fn the_rate_spread_is_recovered_from_the_counts() {
    // Leak only, spread across pixels: counts vary more than Poisson's by the spread.
    let noise = EventNoise {
        leak_hz: 2.0,
        leak_spread_decades: 0.3,
        seed: 4,
        ..EventNoise::default()
    };
    let (w, h) = (96, 72);
    let events = static_stream(w, h, 30, &noise);
    let fitted = fit(
        &events,
        w,
        h,
        Background::Static {
            start_ns: 0,
            end_ns: 30_000_000_000,
        },
    )
    .expect("fit");
    within("spread", fitted.rate_spread_decades, 0.3, 0.1);
    assert!(fitted.shot_noise_hz < 0.01, "{}", fitted.shot_noise_hz);
}

#[test]
fn the_refractory_floor_is_the_refractory_period() {
    let noise = EventNoise {
        refractory_ns: 2_000_000,
        seed: 2,
        ..EventNoise::default()
    };
    let (w, h) = (160, 120);
    let events = moving_stream(w, h, 3, 0.05, &noise);
    let fitted = fit(&events, w, h, Background::Isolated).expect("fit");
    let floor = fitted.refractory_floor_ns.expect("enough intervals") as f64;
    within("refractory floor", floor, 2e6, 0.1);
}

#[test]
fn without_a_static_stretch_the_isolated_events_give_the_background_of_a_moving_scene() {
    let noise = EventNoise {
        shot_noise_hz: 3.0,
        leak_hz: 0.4,
        seed: 8,
        ..EventNoise::default()
    };
    let (w, h) = (160, 120);
    let events = moving_stream(w, h, 10, 0.2, &noise);
    let fitted = fit(&events, w, h, Background::Isolated).expect("fit");
    assert!(fitted.background_events < events.len() as u64 * 9 / 10);
    within("shot noise", fitted.shot_noise_hz, 3.0, 0.1);
    within("leak", fitted.leak_hz, 0.4, 0.1);
}

/// A bar of grey `bar` on grey `ground`, its sharp edges moving 1 px a render, through a
/// sensor with threshold `c`: every pixel the bar passes sees a rise and a fall of `ln(ground/bar)`.
fn bar_stream(c: f64, ground: u8, bar: u8, noise: &EventNoise) -> Vec<Event> {
    let (w, h, bar_px) = (120usize, 40usize, 12usize);
    let mut sensor = NoisyConverter::new(w as u16, h as u16, c, noise).expect("sensor");
    let mut events = Vec::new();
    for k in 0..300usize {
        let left = k % (w + bar_px);
        let mut rgb = vec![ground; w * h * 3];
        for y in 0..h {
            for x in left.saturating_sub(bar_px)..left.min(w) {
                rgb[3 * (y * w + x)..][..3].fill(bar);
            }
        }
        sensor
            .push(k as u64 * RENDER_NS, &rgb, &mut events)
            .expect("frame");
    }
    events
}

#[test]
fn events_per_edge_crossing_are_the_contrast_over_the_threshold() {
    // ln(160/40) = 1.386: 3 events a crossing at threshold 0.4, 5 at 0.25, under shot noise.
    let noise = EventNoise {
        shot_noise_hz: 0.5,
        seed: 3,
        ..EventNoise::default()
    };
    for (c, want) in [(0.4, 3.0), (0.25, 5.0)] {
        let events = bar_stream(c, 160, 40, &noise);
        let fitted = fit(&events, 120, 40, Background::Isolated).expect("fit");
        let x = fitted.crossings;
        assert!(x.on_crossings > 1000 && x.off_crossings > 1000, "{x:?}");
        within(
            "ON per crossing",
            x.on_events_per_crossing.expect("ON"),
            want,
            0.1,
        );
        within(
            "OFF per crossing",
            x.off_events_per_crossing.expect("OFF"),
            want,
            0.1,
        );
    }
}

#[test]
fn the_spread_is_given_by_polarity() {
    // Leak (ON only) spread across pixels, unspread shot noise: the ON counts spread, the OFF
    // counts are Poisson.
    let noise = EventNoise {
        leak_hz: 3.0,
        leak_spread_decades: 0.3,
        shot_noise_hz: 1.0,
        seed: 6,
        ..EventNoise::default()
    };
    let events = static_stream(96, 72, 30, &noise);
    let fitted = fit(
        &events,
        96,
        72,
        Background::Static {
            start_ns: 0,
            end_ns: 30_000_000_000,
        },
    )
    .expect("fit");
    assert!(
        fitted.on_spread_decades > 0.2,
        "{}",
        fitted.on_spread_decades
    );
    assert!(
        fitted.off_spread_decades < 0.05,
        "{}",
        fitted.off_spread_decades
    );
}
