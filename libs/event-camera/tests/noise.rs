//! The noisy converter: bit-identical to the reference with ideal noise, equal to a scalar
//! statement of the noisy rules, and each term's statistics (threshold mismatch, shot noise,
//! leak, refractory period, hot pixels), seeds and validation.

use std::collections::{BTreeMap, BTreeSet, HashMap};

use event_camera::luminance::luminance_key;
use event_camera::noise::LOWPASS_SETTLED;
use event_camera::reference::ReferenceConverter;
use event_camera::synthetic::MovingBlobScene;
use event_camera::{
    CameraConfig, CameraError, ConvertError, Converter, DEFAULT_THRESHOLD, Event, EventCamera,
    EventNoise, NoiseError, NoisyConverter, Polarity,
};
use proptest::prelude::*;
use proto::{EventPacket, PixelRect};

const RENDER_NS: u64 = 10_000_000;

fn gray(width: u16, height: u16, value: u8) -> Vec<u8> {
    vec![value; 3 * usize::from(width) * usize::from(height)]
}

fn noisy(width: u16, height: u16, noise: &EventNoise) -> NoisyConverter {
    NoisyConverter::new(width, height, DEFAULT_THRESHOLD, noise).unwrap()
}

/// Pushes `frames` through `converter`; all events in order.
fn convert(converter: &mut NoisyConverter, frames: &[(u64, Vec<u8>)]) -> Vec<Event> {
    let mut out = Vec::new();
    for (stamp_ns, rgb) in frames {
        converter.push(*stamp_ns, rgb, &mut out).unwrap();
    }
    out
}

/// The same frame every 10 ms from t = 0 through `seconds`.
fn static_frames(rgb: &[u8], seconds: u64) -> Vec<(u64, Vec<u8>)> {
    (0..=seconds * 100)
        .map(|k| (k * RENDER_NS, rgb.to_vec()))
        .collect()
}

fn scene_frames(width: u16, height: u16, count: u64) -> Vec<(u64, Vec<u8>)> {
    let scene = MovingBlobScene::new(width, height);
    (0..count)
        .map(|k| (k * RENDER_NS, scene.frame(k * RENDER_NS)))
        .collect()
}

/// Events per pixel (x, y).
fn by_pixel(events: &[Event]) -> BTreeMap<(u16, u16), Vec<Event>> {
    let mut map: BTreeMap<(u16, u16), Vec<Event>> = BTreeMap::new();
    for e in events {
        map.entry((e.x, e.y)).or_default().push(*e);
    }
    map
}

fn mean_and_std(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, var.sqrt())
}

// ---------------------------------------------------------------------------------------------
// Ideal noise: exactly the reference.

/// How frame k+1 is made from the previous one.
#[derive(Debug, Clone)]
enum Step {
    Random(Vec<u8>),
    Edit(Vec<(usize, u8)>),
    /// The previous frame scaled by num/64.
    Scale(u16),
}

fn frames_strategy(
    max_w: u16,
    max_h: u16,
) -> impl Strategy<Value = (u16, u16, Vec<(u64, Vec<u8>)>)> {
    (1u16..=max_w, 1u16..=max_h)
        .prop_flat_map(|(w, h)| {
            let bytes = usize::from(w) * usize::from(h) * 3;
            let step = prop_oneof![
                prop::collection::vec(any::<u8>(), bytes).prop_map(Step::Random),
                prop::collection::vec((0..bytes, any::<u8>()), 0..12).prop_map(Step::Edit),
                (0u16..=160).prop_map(Step::Scale),
            ];
            (
                Just(w),
                Just(h),
                prop::collection::vec(any::<u8>(), bytes),
                prop::collection::vec((1u64..=50_000_000, step), 1..10),
            )
        })
        .prop_map(|(w, h, first, steps)| {
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
                    Step::Scale(num) => prev
                        .iter()
                        .map(|&b| (u32::from(b) * u32::from(num) / 64).min(255) as u8)
                        .collect(),
                };
                let stamp = frames.last().unwrap().0 + dt_ns;
                frames.push((stamp, next));
            }
            (w, h, frames)
        })
}

/// Asserts the noisy converter with ideal `noise` gives the reference's events and levels.
fn assert_matches_reference(
    width: u16,
    height: u16,
    threshold: f64,
    noise: &EventNoise,
    frames: &[(u64, Vec<u8>)],
) {
    assert!(noise.is_ideal());
    let mut fast = NoisyConverter::new(width, height, threshold, noise).unwrap();
    let mut reference = ReferenceConverter::new(width, height, threshold).unwrap();
    for (k, (stamp_ns, rgb)) in frames.iter().enumerate() {
        let mut got = Vec::new();
        fast.push(*stamp_ns, rgb, &mut got).unwrap();
        assert_eq!(got, reference.push(*stamp_ns, rgb).unwrap(), "frame {k}");
    }
    for y in 0..height {
        for x in 0..width {
            assert_eq!(fast.level(x, y), reference.level(x, y), "level ({x}, {y})");
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn ideal_noise_matches_reference_on_random_frames(
        (w, h, frames) in frames_strategy(45, 9),
        threshold in prop_oneof![Just(DEFAULT_THRESHOLD), 0.01f64..1.5],
        seed in any::<u64>(),
    ) {
        let noise = EventNoise { seed, ..EventNoise::default() };
        assert_matches_reference(w, h, threshold, &noise, &frames);
    }
}

#[test]
fn ideal_noise_matches_reference_on_the_moving_blob_scene() {
    let frames = scene_frames(160, 120, 120);
    for seed in [0, 1, u64::MAX] {
        let noise = EventNoise {
            seed,
            hot_pixel_hz: 30.0, // unused without hot pixels
            ..EventNoise::default()
        };
        assert_matches_reference(160, 120, DEFAULT_THRESHOLD, &noise, &frames);
    }
}

fn unpack(packets: &[EventPacket]) -> Vec<Event> {
    packets
        .iter()
        .flat_map(|p| {
            (0..p.len()).map(|i| Event {
                t_ns: p.t_ns(i),
                x: p.xs[i],
                y: p.ys[i],
                polarity: p.polarity(i),
            })
        })
        .collect()
}

fn camera_packets(config: CameraConfig, frames: &[(u64, Vec<u8>)]) -> Vec<EventPacket> {
    let mut camera = EventCamera::new(config).unwrap();
    let mut packets = Vec::new();
    for (stamp_ns, rgb) in frames {
        packets.extend(camera.push_frame(*stamp_ns, rgb).unwrap());
    }
    packets
}

#[test]
fn camera_with_ideal_noise_equals_the_exact_camera() {
    let (w, h) = (64, 48);
    let frames = scene_frames(w, h, 201);
    let today = camera_packets(CameraConfig::paper(w, h), &frames);
    assert_eq!(CameraConfig::paper(w, h).noise, EventNoise::default());
    let seeded = CameraConfig {
        noise: EventNoise {
            seed: 12_345,
            ..EventNoise::default()
        },
        ..CameraConfig::paper(w, h)
    };
    assert_eq!(camera_packets(seeded, &frames), today);
    // And today's packets hold exactly the exact converter's stream.
    let mut converter = Converter::new(w, h, DEFAULT_THRESHOLD).unwrap();
    let mut want = Vec::new();
    for (stamp_ns, rgb) in &frames {
        converter.push(*stamp_ns, rgb, &mut want).unwrap();
    }
    assert!(!want.is_empty());
    assert_eq!(unpack(&today), want);
}

#[test]
fn noisy_camera_packs_the_noisy_converter_stream() {
    let (w, h) = (64, 48);
    let noise = EventNoise {
        threshold_sigma: 0.03,
        refractory_ns: 500_000,
        leak_hz: 0.5,
        shot_noise_hz: 0.5,
        hot_pixels: 4,
        hot_pixel_hz: 20.0,
        seed: 3,
        ..EventNoise::default()
    };
    let frames = scene_frames(w, h, 201); // 0 .. 2 s: 50 whole packets
    let config = CameraConfig {
        noise,
        ..CameraConfig::paper(w, h)
    };
    let packets = camera_packets(config, &frames);
    assert_eq!(packets.len(), 50);
    let want = convert(&mut noisy(w, h, &noise), &frames);
    assert_eq!(unpack(&packets), want);
    let exact = unpack(&camera_packets(CameraConfig::paper(w, h), &frames));
    assert_ne!(unpack(&packets), exact);
}

// ---------------------------------------------------------------------------------------------
// The noisy rules, stated literally (no shot noise or hot pixels: those are pure draws).

/// Scalar statement of the module docs' rules for the lin-log curve, the low-pass, threshold
/// mismatch, leak (phase, spread, jitter) and refractory period, taking the drawn `C_i`,
/// `φ_i`, `s_i` and `w_{i,m}` from the converter under test.
struct Spec {
    width: usize,
    drawn: NoisyConverter,
    thresholds: Vec<f64>,
    phases: Vec<f64>,
    scales: Vec<f64>,
    noise: EventNoise,
    first_ns: u64,
    last_ns: u64,
    p_init: Vec<f64>,
    p_prev: Vec<f64>,
    level: Vec<i32>,
    last_emit: Vec<Option<u64>>,
}

impl Spec {
    fn of(converter: &NoisyConverter) -> Self {
        let (w, h) = (converter.width(), converter.height());
        let mut thresholds = Vec::new();
        let mut phases = Vec::new();
        let mut scales = Vec::new();
        for y in 0..h {
            for x in 0..w {
                thresholds.push(converter.threshold_of(x, y));
                phases.push(converter.leak_phase_of(x, y));
                scales.push(converter.leak_scale_of(x, y));
            }
        }
        let n = thresholds.len();
        Self {
            width: usize::from(w),
            drawn: converter.clone(),
            thresholds,
            phases,
            scales,
            noise: *converter.noise(),
            first_ns: 0,
            last_ns: 0,
            p_init: Vec::new(),
            p_prev: Vec::new(),
            level: vec![0; n],
            last_emit: vec![None; n],
        }
    }

    /// `Λ_i(g) = φ_i + s_i·J_i(g)`, `J_i` summed from period 0.
    fn leak(&self, i: usize, g: f64) -> f64 {
        let j = if self.noise.leak_jitter == 0.0 {
            g
        } else {
            let (x, y) = ((i % self.width) as u16, (i / self.width) as u16);
            let m = g.floor() as u32;
            let mut sum = 0.0;
            for k in 0..m {
                sum += self.drawn.leak_weight_of(x, y, k);
            }
            sum + self.drawn.leak_weight_of(x, y, m) * (g - f64::from(m))
        };
        self.phases[i] + self.scales[i] * j
    }

    fn push(&mut self, stamp_ns: u64, rgb: &[u8]) -> Vec<Event> {
        let key = |i: usize| luminance_key(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]);
        let lum = |i: usize| self.drawn.log_intensity_of_key(key(i));
        let n = self.thresholds.len();
        if self.p_init.is_empty() {
            self.p_init = (0..n).map(lum).collect();
            self.p_prev = self.p_init.clone();
            (self.first_ns, self.last_ns) = (stamp_ns, stamp_ns);
            return Vec::new();
        }
        let (t0, dt) = (self.last_ns, stamp_ns - self.last_ns);
        let g = |t: u64| self.noise.leak_hz * ((t - self.first_ns) as f64 * 1e-9);
        let mut crossings = Vec::new();
        let mut p_next = Vec::with_capacity(n);
        for i in 0..n {
            let c = self.thresholds[i];
            let l = lum(i);
            let p = if self.noise.cutoff_hz == 0.0 {
                l
            } else {
                let intensity = (f64::from(key(i)) / 1000.0 + 20.0) / 275.0;
                let eps =
                    (intensity * (dt as f64 * 1e-9) * std::f64::consts::TAU * self.noise.cutoff_hz)
                        .min(1.0);
                let next = (1.0 - eps) * self.p_prev[i] + eps * l;
                if eps >= 1.0 || (l - next).abs() <= LOWPASS_SETTLED {
                    l
                } else {
                    next
                }
            };
            p_next.push(p);
            let d = |p: f64, t: u64| {
                if self.noise.leak_hz == 0.0 {
                    p - self.p_init[i]
                } else {
                    (p - self.p_init[i]) + c * self.leak(i, g(t))
                }
            };
            let (d0, d1) = (d(self.p_prev[i], t0), d(p, stamp_ns));
            let time_of = |level: i32| {
                let frac = (f64::from(level) * c - d0) / (d1 - d0);
                t0 + ((frac * dt as f64).ceil() as u64).clamp(1, dt)
            };
            let mut fired = Vec::new();
            while d1 >= f64::from(self.level[i] + 1) * c {
                self.level[i] += 1;
                fired.push((time_of(self.level[i]), Polarity::On));
            }
            while d1 <= f64::from(self.level[i] - 1) * c {
                self.level[i] -= 1;
                fired.push((time_of(self.level[i]), Polarity::Off));
            }
            let refractory_ns = self.noise.refractory_ns;
            for (order, (t, polarity)) in fired.into_iter().enumerate() {
                let ok = self.last_emit[i].is_none_or(|e| t - e >= refractory_ns);
                if refractory_ns == 0 || ok {
                    self.last_emit[i] = Some(t);
                    crossings.push((t, i, order, polarity));
                }
            }
        }
        self.p_prev = p_next;
        crossings.sort_by_key(|&(t, i, order, _)| (t, i, order));
        self.last_ns = stamp_ns;
        crossings
            .into_iter()
            .map(|(t_ns, i, _, polarity)| Event {
                t_ns,
                x: (i % self.width) as u16,
                y: (i / self.width) as u16,
                polarity,
            })
            .collect()
    }
}

fn signal_noise() -> impl Strategy<Value = EventNoise> {
    (
        (
            prop_oneof![Just(0.0), 0.0f64..0.2],
            prop_oneof![Just(0u64), 0u64..20_000_000],
            prop_oneof![Just(0.0), 0.0f64..50.0],
        ),
        (
            prop_oneof![Just(0.0), 0.0f64..0.5],
            prop_oneof![Just(0.0), 0.0f64..0.5],
            prop_oneof![Just(0.0), 0.1f64..60.0],
            prop_oneof![Just(0.0), 1.0f64..60.0],
        ),
        any::<u64>(),
    )
        .prop_map(
            |(
                (threshold_sigma, refractory_ns, leak_hz),
                (leak_spread_decades, leak_jitter, cutoff_hz, linlog_dn),
                seed,
            )| EventNoise {
                threshold_sigma,
                refractory_ns,
                leak_hz,
                leak_spread_decades,
                leak_jitter,
                cutoff_hz,
                linlog_dn,
                seed,
                ..EventNoise::default()
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    #[test]
    fn noisy_converter_follows_the_literal_rules(
        (w, h, frames) in frames_strategy(24, 6),
        noise in signal_noise(),
    ) {
        let mut fast = noisy(w, h, &noise);
        let mut spec = Spec::of(&fast);
        for (k, (stamp_ns, rgb)) in frames.iter().enumerate() {
            let mut got = Vec::new();
            fast.push(*stamp_ns, rgb, &mut got).unwrap();
            prop_assert_eq!(got, spec.push(*stamp_ns, rgb), "frame {}", k);
        }
        for y in 0..h {
            for x in 0..w {
                let i = usize::from(y) * usize::from(w) + usize::from(x);
                prop_assert_eq!(fast.level(x, y), spec.level[i]);
            }
        }
    }
}

/// The smallest rectangle holding every pixel where `a` and `b` differ (None if equal).
fn changed_rect(width: u16, a: &[u8], b: &[u8]) -> Option<PixelRect> {
    let w = usize::from(width);
    let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0, 0);
    for i in 0..a.len() / 3 {
        if a[3 * i..3 * i + 3] != b[3 * i..3 * i + 3] {
            let (x, y) = (i % w, i / w);
            (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
        }
    }
    (x0 != usize::MAX).then(|| PixelRect {
        x: x0 as u16,
        y: y0 as u16,
        width: (x1 - x0 + 1) as u16,
        height: (y1 - y0 + 1) as u16,
    })
}

#[test]
fn region_push_gives_the_events_of_a_full_push() {
    let (w, h) = (96, 72);
    let mut frames = scene_frames(w, h, 150);
    // Some exact repeats: region None.
    for k in [20, 21, 22, 90] {
        frames[k + 1].1 = frames[k].1.clone();
    }
    let base = EventNoise {
        threshold_sigma: 0.04,
        refractory_ns: 2_000_000,
        shot_noise_hz: 1.0,
        hot_pixels: 5,
        hot_pixel_hz: 33.0,
        seed: 17,
        ..EventNoise::default()
    };
    for noise in [
        base,
        EventNoise {
            leak_hz: 1.5,
            ..base
        },
    ] {
        let mut full = noisy(w, h, &noise);
        let mut region = noisy(w, h, &noise);
        let (mut a, mut b) = (Vec::new(), Vec::new());
        full.push(frames[0].0, &frames[0].1, &mut a).unwrap();
        region.push(frames[0].0, &frames[0].1, &mut b).unwrap();
        for k in 1..frames.len() {
            let (stamp_ns, rgb) = &frames[k];
            full.push(*stamp_ns, rgb, &mut a).unwrap();
            let rect = changed_rect(w, &frames[k - 1].1, rgb);
            region.push_region(*stamp_ns, rgb, rect, &mut b).unwrap();
            assert_eq!(a, b, "frame {k} {noise:?}");
        }
        assert!(a.len() > 100);
    }
}

// ---------------------------------------------------------------------------------------------
// Each term's statistics.

#[test]
fn threshold_mismatch_spreads_thresholds_with_sigma() {
    let (w, h) = (64, 48);
    let sigma = 0.03;
    let noise = EventNoise {
        threshold_sigma: sigma,
        seed: 5,
        ..EventNoise::default()
    };
    let mut converter = noisy(w, h, &noise);
    let n = f64::from(w) * f64::from(h);
    let drawn: Vec<f64> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| converter.threshold_of(x, y))
        .collect();
    let (mean, std) = mean_and_std(&drawn);
    // Standard errors: σ/√n for the mean, σ/√(2n) for the standard deviation.
    assert!(
        (mean - DEFAULT_THRESHOLD).abs() < 4.0 * sigma / n.sqrt(),
        "mean {mean}"
    );
    assert!(
        (std - sigma).abs() < 5.0 * sigma / (2.0 * n).sqrt(),
        "std {std}"
    );

    // A uniform ramp from gray 2 to 255: pixel i emits ⌊ΔL / C_i⌋ ON events (± rounding).
    let frames: Vec<(u64, Vec<u8>)> = (2u8..=255)
        .enumerate()
        .map(|(k, v)| (k as u64 * RENDER_NS, gray(w, h, v)))
        .collect();
    let events = convert(&mut converter, &frames);
    assert!(events.iter().all(|e| e.polarity == Polarity::On));
    let span = 255f64.ln() - 2f64.ln();
    let counts = by_pixel(&events);
    let mut inferred = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let count = counts.get(&(x, y)).map_or(0, Vec::len) as f64;
            let want = (span / converter.threshold_of(x, y)).floor();
            assert!((count - want).abs() <= 1.0, "({x}, {y}): {count} vs {want}");
            inferred.push(span / (count + 0.5));
        }
    }
    let (mean, std) = mean_and_std(&inferred);
    assert!(
        (mean / DEFAULT_THRESHOLD - 1.0).abs() < 0.03,
        "inferred mean {mean}"
    );
    assert!((std / sigma - 1.0).abs() < 0.15, "inferred std {std}");
}

#[test]
fn shot_noise_count_is_poisson_with_fair_polarity() {
    let (w, h) = (64, 48);
    let (rate, seconds) = (5.0, 10);
    let noise = EventNoise {
        shot_noise_hz: rate,
        seed: 11,
        ..EventNoise::default()
    };
    let events = convert(
        &mut noisy(w, h, &noise),
        &static_frames(&gray(w, h, 120), seconds),
    );
    let lambda = rate * f64::from(w) * f64::from(h) * seconds as f64;
    let count = events.len() as f64;
    // 99.9 % two-sided interval of Poisson(λ), λ ≈ 1.5e5 (normal approximation).
    assert!(
        (count - lambda).abs() < 3.29 * lambda.sqrt(),
        "{count} vs {lambda}"
    );
    let on = events.iter().filter(|e| e.polarity == Polarity::On).count() as f64;
    assert!(
        (on / count - 0.5).abs() < 3.29 * 0.5 / count.sqrt(),
        "ON {on}/{count}"
    );
    // Spread over the sensor (≈ 50 per pixel) and time-ordered in (0, T].
    assert_eq!(by_pixel(&events).len(), usize::from(w) * usize::from(h));
    assert!(events.windows(2).all(|p| p[0].t_ns <= p[1].t_ns));
    let end = seconds * 1_000_000_000;
    assert!(events.iter().all(|e| e.t_ns > 0 && e.t_ns <= end));
    // Uniform in time: about half in the first half of the run.
    let early = events.iter().filter(|e| e.t_ns <= end / 2).count() as f64;
    assert!((early / count - 0.5).abs() < 3.29 * 0.5 / count.sqrt());
}

#[test]
fn leak_makes_static_pixels_emit_on_events_at_the_leak_rate() {
    let (w, h) = (32, 24);
    let (rate, seconds) = (2.0, 10);
    for value in [0u8, 100] {
        let noise = EventNoise {
            leak_hz: rate,
            seed: 23,
            ..EventNoise::default()
        };
        let mut converter = noisy(w, h, &noise);
        let events = convert(&mut converter, &static_frames(&gray(w, h, value), seconds));
        assert!(events.iter().all(|e| e.polarity == Polarity::On));
        let per_pixel = by_pixel(&events);
        assert_eq!(per_pixel.len(), usize::from(w) * usize::from(h));
        let want = rate * seconds as f64;
        let mut phases = Vec::new();
        for ((x, y), list) in &per_pixel {
            assert!(
                (list.len() as f64 - want).abs() <= 1.0,
                "({x}, {y}): {}",
                list.len()
            );
            // First crossing when φ + rate·t reaches 1: t = (1 − φ) / rate, to a frame.
            let phase = converter.leak_phase_of(*x, *y);
            let first_s = list[0].t_ns as f64 * 1e-9;
            assert!(
                (first_s - (1.0 - phase) / rate).abs() <= 0.0101,
                "({x}, {y})"
            );
            phases.push(phase);
        }
        let mean_rate = events.len() as f64 / per_pixel.len() as f64 / seconds as f64;
        assert!((mean_rate / rate - 1.0).abs() < 0.02, "rate {mean_rate}");
        let (mean, std) = mean_and_std(&phases);
        assert!((mean - 0.5).abs() < 0.05 && (std - (1.0f64 / 12.0).sqrt()).abs() < 0.03);
    }
}

#[test]
fn leak_spread_and_jitter_follow_their_definitions() {
    let (w, h) = (32, 24);
    let (rate, seconds) = (5.0, 40);
    let noise = EventNoise {
        leak_hz: rate,
        leak_spread_decades: 0.2,
        leak_jitter: 0.3,
        seed: 29,
        ..EventNoise::default()
    };
    let mut converter = noisy(w, h, &noise);
    let events = convert(&mut converter, &static_frames(&gray(w, h, 90), seconds));
    let mut log_scales = Vec::new();
    let mut log_rates = Vec::new();
    let mut interval_cv = Vec::new();
    for ((x, y), list) in &by_pixel(&events) {
        let scale = converter.leak_scale_of(*x, *y);
        log_scales.push(scale.log10());
        let times: Vec<f64> = list.iter().map(|e| e.t_ns as f64 * 1e-9).collect();
        let span = times[times.len() - 1] - times[0];
        log_rates.push(((times.len() - 1) as f64 / span / rate).log10());
        // Each interval is one leak period at the rate drawn for it: relative σ ≈ j (the
        // rate changes at the nominal period, so an interval straddles one or two draws).
        let intervals: Vec<f64> = times.windows(2).map(|t| t[1] - t[0]).collect();
        let (mean, std) = mean_and_std(&intervals);
        interval_cv.push(std / mean);
    }
    // s_i = 10^(σ·z): log10 spread σ, and each pixel's measured rate follows its own s_i.
    let (mean, std) = mean_and_std(&log_scales);
    assert!(
        mean.abs() < 0.02 && (std - 0.2).abs() < 0.02,
        "{mean} {std}"
    );
    let (rmean, rstd) = mean_and_std(&log_rates);
    assert!(
        (rmean - mean).abs() < 0.02 && (rstd - std).abs() < 0.03,
        "{rmean} {rstd}"
    );
    let (cv, _) = mean_and_std(&interval_cv);
    assert!((0.15..0.35).contains(&cv), "interval cv {cv}");
    // Without jitter the intervals are regular (to a frame).
    let steady = EventNoise {
        leak_jitter: 0.0,
        ..noise
    };
    let events = convert(
        &mut noisy(w, h, &steady),
        &static_frames(&gray(w, h, 90), 10),
    );
    for list in by_pixel(&events).values() {
        let intervals: Vec<f64> = list
            .windows(2)
            .map(|e| (e[1].t_ns - e[0].t_ns) as f64)
            .collect();
        let (mean, std) = mean_and_std(&intervals);
        assert!(std / mean < 0.06, "{}", std / mean);
    }
}

#[test]
fn shot_noise_scales_with_threshold_and_falls_in_bright_pixels() {
    let (w, h) = (64, 48);
    let seconds = 20;
    // Left half black, right half white.
    let mut frame = gray(w, h, 0);
    for y in 0..usize::from(h) {
        for x in usize::from(w) / 2..usize::from(w) {
            let i = 3 * (y * usize::from(w) + x);
            frame[i..i + 3].copy_from_slice(&[255, 255, 255]);
        }
    }
    let noise = EventNoise {
        shot_noise_hz: 2.0,
        shot_noise_bright_drop: 0.75,
        threshold_sigma: 0.04,
        seed: 31,
        ..EventNoise::default()
    };
    let mut converter = noisy(w, h, &noise);
    let events = convert(&mut converter, &static_frames(&frame, seconds));
    let (mut dark, mut bright) = (0.0, 0.0);
    // Expected counts: rate · C/C_i · (1 − b·I) · time, per half.
    let (mut want_dark, mut want_bright) = (0.0, 0.0);
    for y in 0..h {
        for x in 0..w {
            let weight = DEFAULT_THRESHOLD / converter.threshold_of(x, y);
            if x < w / 2 {
                want_dark += 2.0 * weight * (1.0 - 0.75 * 20.0 / 275.0) * seconds as f64;
            } else {
                want_bright += 2.0 * weight * 0.25 * seconds as f64;
            }
        }
    }
    for e in &events {
        if e.x < w / 2 {
            dark += 1.0;
        } else {
            bright += 1.0;
        }
    }
    for (got, want) in [(dark, want_dark), (bright, want_bright)] {
        assert!((got - want).abs() < 4.0 * want.sqrt(), "{got} vs {want}");
    }
    // Low-threshold pixels are noisier in proportion.
    let (mut low, mut n_low, mut high, mut n_high) = (0.0, 0.0, 0.0, 0.0);
    let counts = by_pixel(&events);
    for y in 0..h {
        for x in 0..w / 2 {
            let n = counts.get(&(x, y)).map_or(0.0, |l| l.len() as f64);
            if converter.threshold_of(x, y) < DEFAULT_THRESHOLD {
                (low, n_low) = (low + n, n_low + 1.0);
            } else {
                (high, n_high) = (high + n, n_high + 1.0);
            }
        }
    }
    assert!(
        low / n_low > 1.2 * (high / n_high),
        "{} {}",
        low / n_low,
        high / n_high
    );
}

#[test]
fn refractory_period_spaces_each_pixels_events() {
    let (w, h) = (16, 12);
    let refractory_ns = 3_000_000;
    // Alternating dim/bright every 10 ms: ≈ 17 crossings per pixel per interval, ≈ 0.6 ms apart.
    let frames: Vec<(u64, Vec<u8>)> = (0..60u64)
        .map(|k| (k * RENDER_NS, gray(w, h, if k % 2 == 0 { 10 } else { 250 })))
        .collect();
    let min_gap = |events: &[Event]| {
        by_pixel(events)
            .values()
            .flat_map(|list| list.windows(2).map(|p| p[1].t_ns - p[0].t_ns))
            .min()
            .unwrap()
    };
    let free = convert(&mut noisy(w, h, &EventNoise::default()), &frames);
    assert!(
        min_gap(&free) < refractory_ns,
        "the input must be fast enough"
    );
    let noise = EventNoise {
        refractory_ns,
        ..EventNoise::default()
    };
    let mut converter = noisy(w, h, &noise);
    let events = convert(&mut converter, &frames);
    assert!(min_gap(&events) >= refractory_ns);
    assert!(
        events.len() < free.len() / 3,
        "{} of {}",
        events.len(),
        free.len()
    );
    assert!(events.iter().any(|e| e.polarity == Polarity::Off));
    // The level still follows the input: the same as without the refractory period.
    let mut exact = Converter::new(w, h, DEFAULT_THRESHOLD).unwrap();
    let mut sink = Vec::new();
    for (stamp_ns, rgb) in &frames {
        exact.push(*stamp_ns, rgb, &mut sink).unwrap();
    }
    assert_eq!(converter.level(3, 4), exact.level(3, 4));
    assert_ne!(exact.level(3, 4), 0);
}

#[test]
fn hot_pixels_fire_periodically_at_distinct_pixels() {
    let (w, h) = (64, 48);
    let (count, rate, seconds) = (10u32, 50.0, 2);
    let noise = EventNoise {
        hot_pixels: count,
        hot_pixel_hz: rate,
        seed: 8,
        ..EventNoise::default()
    };
    let mut converter = noisy(w, h, &noise);
    let events = convert(&mut converter, &static_frames(&gray(w, h, 0), seconds));
    let per_pixel = by_pixel(&events);
    assert_eq!(per_pixel.len(), count as usize);
    let hot: BTreeSet<(u16, u16)> = converter.hot_pixel_positions().into_iter().collect();
    assert_eq!(hot.len(), count as usize);
    assert_eq!(per_pixel.keys().copied().collect::<BTreeSet<_>>(), hot);
    let period_ns = 1e9 / rate;
    for list in per_pixel.values() {
        assert_eq!(list.len(), (rate * seconds as f64) as usize);
        assert!(list.iter().all(|e| e.polarity == Polarity::On));
        for p in list.windows(2) {
            assert!(((p[1].t_ns - p[0].t_ns) as f64 - period_ns).abs() <= 1.0);
        }
    }
    // Random phases: the first events are not all at the same time.
    let firsts: BTreeSet<u64> = per_pixel.values().map(|l| l[0].t_ns).collect();
    assert!(firsts.len() > 1);
}

// ---------------------------------------------------------------------------------------------
// Seeds, independence of the terms, validation.

fn everything(seed: u64) -> EventNoise {
    EventNoise {
        threshold_sigma: 0.03,
        refractory_ns: 300_000,
        leak_hz: 0.3,
        shot_noise_hz: 1.0,
        hot_pixels: 6,
        hot_pixel_hz: 40.0,
        leak_spread_decades: 0.1,
        leak_jitter: 0.1,
        shot_noise_bright_drop: 0.75,
        cutoff_hz: 30.0,
        linlog_dn: 20.0,
        seed,
    }
}

#[test]
fn same_seed_gives_identical_events_and_another_seed_different_ones() {
    let (w, h) = (64, 48);
    let frames = scene_frames(w, h, 60);
    let a = convert(&mut noisy(w, h, &everything(1)), &frames);
    let again = convert(&mut noisy(w, h, &everything(1)), &frames);
    let other = convert(&mut noisy(w, h, &everything(2)), &frames);
    assert!(a.len() > 1000);
    assert_eq!(a, again);
    assert_ne!(a, other);
    // A clone continues identically.
    let mut converter = noisy(w, h, &everything(1));
    let head = convert(&mut converter, &frames[..30]);
    let mut twin = converter.clone();
    let (mut x, mut y) = (head.clone(), head);
    for (stamp_ns, rgb) in &frames[30..] {
        converter.push(*stamp_ns, rgb, &mut x).unwrap();
        twin.push(*stamp_ns, rgb, &mut y).unwrap();
    }
    assert_eq!(x, a);
    assert_eq!(y, a);
}

#[test]
fn each_term_draws_from_its_own_stream() {
    let (w, h) = (64, 48);
    let frames = scene_frames(w, h, 60);
    let mismatch = EventNoise {
        threshold_sigma: 0.05,
        seed: 9,
        ..EventNoise::default()
    };
    let plus_noise = EventNoise {
        shot_noise_hz: 2.0,
        hot_pixels: 3,
        hot_pixel_hz: 25.0,
        ..mismatch
    };
    let mut a = noisy(w, h, &mismatch);
    let mut b = noisy(w, h, &plus_noise);
    for (x, y) in [(0, 0), (5, 7), (63, 47)] {
        assert_eq!(a.threshold_of(x, y), b.threshold_of(x, y));
    }
    // The threshold crossings are the same; shot and hot events are merged in.
    let (ea, eb) = (convert(&mut a, &frames), convert(&mut b, &frames));
    let mut extra: HashMap<Event, i64> = HashMap::new();
    for e in &eb {
        *extra.entry(*e).or_default() += 1;
    }
    for e in &ea {
        let n = extra.get_mut(e).expect("every crossing is still there");
        *n -= 1;
        assert!(*n >= 0);
    }
    assert!(eb.len() > ea.len());
    // The leak phases do not depend on the other terms either.
    let leak = |other: EventNoise| {
        let c = noisy(
            w,
            h,
            &EventNoise {
                leak_hz: 1.0,
                ..other
            },
        );
        (c.leak_phase_of(1, 2), c.leak_phase_of(40, 30))
    };
    assert_eq!(leak(mismatch), leak(plus_noise));
    assert_eq!(
        noisy(w, h, &plus_noise).hot_pixel_positions(),
        noisy(
            w,
            h,
            &EventNoise {
                leak_hz: 1.0,
                ..plus_noise
            }
        )
        .hot_pixel_positions()
    );
}

/// Sets one f64 field of the noise.
type Setter = fn(&mut EventNoise, f64);

#[test]
fn validate_rejects_bad_values_naming_the_field() {
    let base = EventNoise::default();
    let cases: [(&str, Setter); 9] = [
        ("threshold_sigma", |n, v| n.threshold_sigma = v),
        ("leak_hz", |n, v| n.leak_hz = v),
        ("leak_spread_decades", |n, v| n.leak_spread_decades = v),
        ("leak_jitter", |n, v| n.leak_jitter = v),
        ("shot_noise_hz", |n, v| n.shot_noise_hz = v),
        ("shot_noise_bright_drop", |n, v| {
            n.shot_noise_bright_drop = v
        }),
        ("cutoff_hz", |n, v| n.cutoff_hz = v),
        ("linlog_dn", |n, v| n.linlog_dn = v),
        ("hot_pixel_hz", |n, v| n.hot_pixel_hz = v),
    ];
    for (field, set) in cases {
        for value in [-1.0, -1e-12, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let mut noise = base;
            set(&mut noise, value);
            let err = noise.validate().unwrap_err();
            match &err {
                NoiseError::NotFiniteNonNegative { field: f, value: v } => {
                    assert_eq!(*f, field);
                    assert!(v.to_bits() == value.to_bits());
                }
                other => panic!("{field} = {value}: {other:?}"),
            }
            assert!(err.to_string().contains(field), "{err}");
            // The camera refuses it too.
            let config = CameraConfig {
                noise,
                ..CameraConfig::paper(8, 8)
            };
            assert!(matches!(
                EventCamera::new(config),
                Err(CameraError::Convert(ConvertError::Noise(_)))
            ));
            assert!(NoisyConverter::new(8, 8, DEFAULT_THRESHOLD, &noise).is_err());
        }
        if field != "threshold_sigma" {
            let mut noise = base;
            set(&mut noise, 1e7);
            let err = noise.validate().unwrap_err();
            assert!(matches!(err, NoiseError::TooLarge { field: f, .. } if f == field));
            assert!(err.to_string().contains(field), "{err}");
        }
    }
    let no_rate = EventNoise {
        hot_pixels: 2,
        ..base
    };
    let err = no_rate.validate().unwrap_err();
    assert!(matches!(
        err,
        NoiseError::HotPixelRateNotPositive { hot_pixels: 2, .. }
    ));
    assert!(err.to_string().contains("hot_pixel_hz"), "{err}");
    let too_many = EventNoise {
        hot_pixels: 65,
        hot_pixel_hz: 1.0,
        ..base
    };
    assert_eq!(too_many.validate(), Ok(()));
    let err = NoisyConverter::new(8, 8, DEFAULT_THRESHOLD, &too_many).unwrap_err();
    assert_eq!(
        err,
        ConvertError::Noise(NoiseError::TooManyHotPixels {
            hot_pixels: 65,
            pixels: 64
        })
    );
    assert!(err.to_string().contains("hot_pixels"), "{err}");
    // The usual converter errors still apply.
    assert!(matches!(
        NoisyConverter::new(8, 8, 0.0, &base),
        Err(ConvertError::BadThreshold(_))
    ));
    assert!(matches!(
        NoisyConverter::new(0, 8, DEFAULT_THRESHOLD, &base),
        Err(ConvertError::EmptySensor { .. })
    ));
}

#[test]
fn frame_errors_change_nothing() {
    let noise = everything(4);
    let (w, h) = (20, 10);
    let mut converter = noisy(w, h, &noise);
    let mut out = Vec::new();
    assert!(matches!(
        converter.push_region(0, &gray(w, h, 9), None, &mut out),
        Err(ConvertError::RegionBeforeFirstFrame)
    ));
    converter.push(100, &gray(w, h, 9), &mut out).unwrap();
    let before = converter.clone();
    assert!(matches!(
        converter.push(100, &gray(w, h, 50), &mut out),
        Err(ConvertError::StampNotIncreasing { .. })
    ));
    assert!(matches!(
        converter.push(200, &[0; 5], &mut out),
        Err(ConvertError::FrameSize { .. })
    ));
    let outside = PixelRect {
        x: 15,
        y: 0,
        width: 6,
        height: 1,
    };
    assert!(matches!(
        converter.push_region(200, &gray(w, h, 9), Some(outside), &mut out),
        Err(ConvertError::RegionOutside { .. })
    ));
    assert!(out.is_empty());
    let frames = static_frames(&gray(w, h, 9), 1);
    let mut a = converter;
    let mut b = before;
    assert_eq!(convert(&mut a, &frames[1..]), convert(&mut b, &frames[1..]));
}
