//! Template matching of image-plane paths against the four action templates.
//!
//! Both receivers resample a candidate path to [`RESAMPLE_POINTS`] arc-length-spaced points,
//! subtract their centroid and divide by the path's largest coordinate span, then score it by the
//! RMS distance `E_a` to each template (normalised the same way), after the best order-preserving
//! re-registration of the samples within ±[`WARP_BAND`] ([`warped_rms_error`]). Dividing by the *largest* span
//! (not per axis) keeps a pure vertical START and a pure horizontal END distinct instead of
//! blowing up the flat axis.
//!
//! Subtracting the centroid makes `E_a` the RMS distance after the least-squares best
//! translation (the centroid difference), so an offset of the whole path costs nothing. The
//! paper's rule subtracted the first point instead: that single point (the previous rest's mean)
//! then carried its full offset into every one of the 80 distances. A performer whose position
//! estimate wanders slowly (a real cascade controller follows its estimate, ≈ 0.3–0.7 Hz, the
//! gesture's own band, so no filter separates the two) rests a few pixels away from where it
//! then flies the stroke; with the first point as origin that alone pushed correct strokes past
//! the error limit (issue 28). Template separation is unchanged where it is smallest (START vs
//! END 0.41, the acquisition sweep vs END 0.41: both pairs are centred already).
//!
//! The warp (banded dynamic time warping) answers the next distortion of that flight: wander
//! during a stroke adds arc length to part of it, so the later samples slide along a correctly
//! shaped path and the fixed pairing measures the slide. It never costs more than the fixed
//! pairing, and the templates stay apart (closest pair START/END 0.41 → 0.35, still far above
//! the runner-up margins of 0.065–0.075).
//! Acceptance additionally requires minimum support, closure, an error limit and a margin over
//! the runner-up; a rejected path says which test failed.

use std::sync::OnceLock;

use serde::{Deserialize, Serialize};

use crate::token::Action;

/// Number of arc-length samples a path and every template are reduced to.
pub const RESAMPLE_POINTS: usize = 80;

/// Per-modality acceptance settings (paper, Table "Receiver settings").
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MatchSettings {
    /// Largest accepted best-template RMS error (normalised units).
    pub error_limit: f64,
    /// Smallest accepted gap between runner-up and best error.
    pub runner_up_margin: f64,
    /// Fewest path points accepted.
    pub min_points: usize,
    /// Smallest accepted largest coordinate span of the path, pixels.
    pub min_span_px: f64,
    /// Largest accepted |last − first| / largest coordinate span.
    pub closure_limit: f64,
}

impl MatchSettings {
    /// Settings of the RGB receiver.
    pub fn rgb() -> Self {
        Self {
            error_limit: 0.17,
            runner_up_margin: 0.075,
            min_points: 12,
            min_span_px: 28.0,
            closure_limit: 0.18,
        }
    }

    /// Settings of the event receiver.
    pub fn events() -> Self {
        Self {
            error_limit: 0.21,
            runner_up_margin: 0.065,
            min_points: 12,
            min_span_px: 28.0,
            closure_limit: 0.20,
        }
    }
}

/// An accepted path.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Classification {
    pub action: Action,
    /// RMS error to the best template.
    pub error: f64,
    /// RMS error to the second-best template.
    pub runner_up_error: f64,
    /// RMS error to every template, indexed like [`Action::ALL`].
    pub errors: [f64; 4],
    /// Largest coordinate span of the raw path, pixels.
    pub span_px: f64,
    /// |last − first| / span.
    pub closure: f64,
}

/// Why a path was not accepted as an action.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, thiserror::Error)]
pub enum Rejection {
    #[error("path has a non-finite coordinate")]
    NonFinite,
    #[error("path has {points} points, fewer than {min}")]
    TooFewPoints { points: usize, min: usize },
    #[error("path spans {span_px:.1} px, less than {min_px:.1} px")]
    TooSmallSpan { span_px: f64, min_px: f64 },
    #[error("path is not closed: end-to-start gap is {closure:.3} of its span (limit {limit:.3})")]
    NotClosed { closure: f64, limit: f64 },
    #[error("best template {best} has error {error:.3}, above the limit {limit:.3}")]
    NoTemplateClose {
        best: Action,
        error: f64,
        limit: f64,
        errors: [f64; 4],
    },
    #[error(
        "ambiguous: {best} ({error:.3}) vs {runner_up} ({runner_up_error:.3}), margin below {margin:.3}"
    )]
    Ambiguous {
        best: Action,
        error: f64,
        runner_up: Action,
        runner_up_error: f64,
        margin: f64,
        errors: [f64; 4],
    },
}

/// Resamples `path` to `n` points equally spaced along its arc length, first and last points
/// kept. An empty path gives an empty result; a path of zero length gives `n` copies of its
/// first point.
pub fn resample_arc_length(path: &[[f64; 2]], n: usize) -> Vec<[f64; 2]> {
    let Some(&first) = path.first() else {
        return Vec::new();
    };
    if n == 0 {
        return Vec::new();
    }
    let mut cumulative = Vec::with_capacity(path.len());
    let mut total = 0.0;
    cumulative.push(0.0);
    for w in path.windows(2) {
        total += dist(w[0], w[1]);
        cumulative.push(total);
    }
    if total <= 0.0 || !total.is_finite() || n == 1 {
        return vec![first; n];
    }
    let mut out = Vec::with_capacity(n);
    let mut seg = 0;
    for k in 0..n {
        let target = total * k as f64 / (n - 1) as f64;
        while seg + 2 < path.len() && cumulative[seg + 1] < target {
            seg += 1;
        }
        let (a, b) = (path[seg], path[(seg + 1).min(path.len() - 1)]);
        let len = cumulative[(seg + 1).min(path.len() - 1)] - cumulative[seg];
        let t = if len > 0.0 {
            ((target - cumulative[seg]) / len).clamp(0.0, 1.0)
        } else {
            0.0
        };
        out.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
    }
    out
}

/// Largest coordinate span (max over x and y of max − min) of a path; 0 for an empty path.
pub fn largest_span(path: &[[f64; 2]]) -> f64 {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for p in path {
        for d in 0..2 {
            lo[d] = lo[d].min(p[d]);
            hi[d] = hi[d].max(p[d]);
        }
    }
    if path.is_empty() {
        0.0
    } else {
        (hi[0] - lo[0]).max(hi[1] - lo[1])
    }
}

/// Subtracts the centroid (mean point) and divides by the largest coordinate span. Applied to an
/// arc-length resampled path, the centroid is the path's own, independent of how densely each
/// part was sampled. A path with zero span is only translated (all zeros), never divided by
/// zero.
pub fn normalise(path: &[[f64; 2]]) -> Vec<[f64; 2]> {
    if path.is_empty() {
        return Vec::new();
    }
    let n = path.len() as f64;
    let o = path
        .iter()
        .fold([0.0, 0.0], |acc, p| [acc[0] + p[0] / n, acc[1] + p[1] / n]);
    let span = largest_span(path);
    let scale = if span > 0.0 { 1.0 / span } else { 1.0 };
    path.iter()
        .map(|p| [(p[0] - o[0]) * scale, (p[1] - o[1]) * scale])
        .collect()
}

/// RMS point-to-point distance between two equally long point sequences (compared up to the
/// shorter one); infinite when either is empty.
pub fn rms_error(a: &[[f64; 2]], b: &[[f64; 2]]) -> f64 {
    let n = a.len().min(b.len());
    if n == 0 {
        return f64::INFINITY;
    }
    let sum: f64 = a.iter().zip(b).map(|(p, q)| dist_sq(*p, *q)).sum();
    (sum / n as f64).sqrt()
}

/// Largest shift, in samples, by which [`warped_rms_error`] may slide a path's samples along its
/// template (±10 % of the [`RESAMPLE_POINTS`]).
pub const WARP_BAND: usize = 8;

/// RMS distance between two point sequences after the best order-preserving re-registration of
/// their samples: dynamic time warping with the symmetric step pattern (a diagonal step weighs
/// twice, a horizontal or vertical one once, normalised by `a.len() + b.len()`) inside a
/// Sakoe–Chiba band of `band` samples. Without warping (the diagonal) this is exactly
/// [`rms_error`], so it is never larger; infinite when either sequence is empty.
///
/// Why: a performer that wanders while flying a stroke adds length to parts of its path, so
/// its 80 arc-length samples slide along the template's shape even when the shape is right;
/// the fixed pairing then measures the slide, not the shape (issue 28). The band keeps the
/// pairing local, so the shape's order still decides (a V cannot become an inverted V).
pub fn warped_rms_error(a: &[[f64; 2]], b: &[[f64; 2]], band: usize) -> f64 {
    let (n, m) = (a.len(), b.len());
    if n == 0 || m == 0 {
        return f64::INFINITY;
    }
    // Row-by-row cumulative cost; cells outside the band stay infinite.
    let mut prev = vec![f64::INFINITY; m];
    let mut row = vec![f64::INFINITY; m];
    for i in 0..n {
        row.fill(f64::INFINITY);
        let (lo, hi) = (i.saturating_sub(band), (i + band).min(m - 1));
        for j in lo..=hi {
            let d = dist_sq(a[i], b[j]);
            row[j] = if i == 0 && j == 0 {
                2.0 * d
            } else {
                let diagonal = if i > 0 && j > 0 {
                    prev[j - 1] + 2.0 * d
                } else {
                    f64::INFINITY
                };
                let vertical = if i > 0 { prev[j] + d } else { f64::INFINITY };
                let horizontal = if j > 0 { row[j - 1] + d } else { f64::INFINITY };
                diagonal.min(vertical).min(horizontal)
            };
        }
        std::mem::swap(&mut prev, &mut row);
    }
    (prev[m - 1] / (n + m) as f64).sqrt()
}

/// The normalised, resampled template of `action` (image coordinates, y down).
pub fn template(action: Action) -> &'static [[f64; 2]] {
    static TEMPLATES: OnceLock<[Vec<[f64; 2]>; 4]> = OnceLock::new();
    let all = TEMPLATES.get_or_init(|| {
        Action::ALL.map(|a| normalise(&resample_arc_length(&a.image_polyline(), RESAMPLE_POINTS)))
    });
    &all[action.index()]
}

/// Error of a raw image path to every template ([`warped_rms_error`] within [`WARP_BAND`]),
/// indexed like [`Action::ALL`].
pub fn template_errors(path_px: &[[f64; 2]]) -> [f64; 4] {
    let u = normalise(&resample_arc_length(path_px, RESAMPLE_POINTS));
    Action::ALL.map(|a| warped_rms_error(&u, template(a), WARP_BAND))
}

/// Classifies a raw image-plane path (pixels, y down) as one of the four actions.
pub fn classify(
    path_px: &[[f64; 2]],
    settings: &MatchSettings,
) -> Result<Classification, Rejection> {
    if path_px
        .iter()
        .any(|p| !p[0].is_finite() || !p[1].is_finite())
    {
        return Err(Rejection::NonFinite);
    }
    if path_px.len() < settings.min_points || path_px.is_empty() {
        return Err(Rejection::TooFewPoints {
            points: path_px.len(),
            min: settings.min_points,
        });
    }
    let span_px = largest_span(path_px);
    if span_px < settings.min_span_px {
        return Err(Rejection::TooSmallSpan {
            span_px,
            min_px: settings.min_span_px,
        });
    }
    let first = path_px[0];
    let last = path_px[path_px.len() - 1];
    // A zero-span path has coinciding ends (coordinates are finite, checked above).
    let closure = if span_px > 0.0 {
        dist(first, last) / span_px
    } else {
        0.0
    };
    if closure > settings.closure_limit {
        return Err(Rejection::NotClosed {
            closure,
            limit: settings.closure_limit,
        });
    }
    let errors = template_errors(path_px);
    let mut order = [0usize, 1, 2, 3];
    order.sort_by(|&i, &j| errors[i].total_cmp(&errors[j]).then(i.cmp(&j)));
    let (best, runner_up) = (Action::ALL[order[0]], Action::ALL[order[1]]);
    let (error, runner_up_error) = (errors[order[0]], errors[order[1]]);
    if error > settings.error_limit {
        return Err(Rejection::NoTemplateClose {
            best,
            error,
            limit: settings.error_limit,
            errors,
        });
    }
    if runner_up_error - error < settings.runner_up_margin {
        return Err(Rejection::Ambiguous {
            best,
            error,
            runner_up,
            runner_up_error,
            margin: settings.runner_up_margin,
            errors,
        });
    }
    Ok(Classification {
        action: best,
        error,
        runner_up_error,
        errors,
        span_px,
        closure,
    })
}

fn dist_sq(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    dist_sq(a, b).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The action's polyline drawn at `scale_px` around `origin_px`, sampled at `per_segment`
    /// evenly spaced points per segment (as a tracker sampling at a fixed rate would).
    fn drawn(
        action: Action,
        scale_px: f64,
        origin_px: [f64; 2],
        per_segment: usize,
    ) -> Vec<[f64; 2]> {
        let poly = action.image_polyline();
        let mut out = Vec::new();
        for w in poly.windows(2) {
            for s in 0..per_segment {
                let t = s as f64 / per_segment as f64;
                out.push([
                    origin_px[0] + scale_px * (w[0][0] + t * (w[1][0] - w[0][0])),
                    origin_px[1] + scale_px * (w[0][1] + t * (w[1][1] - w[0][1])),
                ]);
            }
        }
        let end = poly[poly.len() - 1];
        out.push([
            origin_px[0] + scale_px * end[0],
            origin_px[1] + scale_px * end[1],
        ]);
        out
    }

    fn action_strategy() -> impl Strategy<Value = Action> {
        prop::sample::select(Action::ALL.to_vec())
    }

    #[test]
    fn templates_have_80_points_centroid_at_origin_and_unit_span() {
        for a in Action::ALL {
            let t = template(a);
            assert_eq!(t.len(), RESAMPLE_POINTS);
            let c = t
                .iter()
                .fold([0.0, 0.0], |acc, p| [acc[0] + p[0], acc[1] + p[1]]);
            assert!(
                c[0].abs() < 1e-12 && c[1].abs() < 1e-12,
                "{a}: centroid sum {c:?}"
            );
            assert!(
                (largest_span(t) - 1.0).abs() < 1e-12,
                "{a}: span {}",
                largest_span(t)
            );
        }
        // START stays a vertical line and END a horizontal one after normalisation.
        assert!(template(Action::Start).iter().all(|p| p[0] == 0.0));
        assert!(template(Action::End).iter().all(|p| p[1] == 0.0));
    }

    #[test]
    fn each_template_classifies_as_itself_with_zero_error() {
        for settings in [MatchSettings::rgb(), MatchSettings::events()] {
            for a in Action::ALL {
                let c = classify(&drawn(a, 90.0, [320.0, 240.0], 8), &settings).expect("accepted");
                assert_eq!(c.action, a);
                assert!(c.error < 1e-9, "{a}: {}", c.error);
                assert!(c.runner_up_error > settings.error_limit + settings.runner_up_margin);
            }
        }
    }

    #[test]
    fn a_slow_offset_of_the_stroke_costs_little_error() {
        // A performer following a slowly wandering position estimate flies the stroke offset
        // from where it rested before and after: a half-sine bump, zero at both rests, 10 % of
        // the span at mid-symbol, in eight directions. Measured from the first point (the
        // previous rest) this cost ≈ 0.097; after the best translation it costs ≈ 0.059.
        for a in Action::ALL {
            for k in 0..8 {
                let dir = std::f64::consts::TAU * f64::from(k) / 8.0;
                let mut path = drawn(a, 90.0, [320.0, 240.0], 8);
                let amp = 0.10 * largest_span(&path);
                let last = (path.len() - 1) as f64;
                for (i, p) in path.iter_mut().enumerate() {
                    let bump = amp * (std::f64::consts::PI * i as f64 / last).sin();
                    p[0] += bump * dir.cos();
                    p[1] += bump * dir.sin();
                }
                let c = classify(&path, &MatchSettings::rgb()).expect("accepted");
                assert_eq!(c.action, a);
                assert!(c.error < 0.065, "{a} direction {k}: error {:.3}", c.error);
            }
        }
    }

    #[test]
    fn warping_never_costs_more_than_the_fixed_pairing_and_nothing_on_itself() {
        for a in Action::ALL {
            let t = template(a);
            assert_eq!(warped_rms_error(t, t, WARP_BAND), 0.0);
            for b in Action::ALL {
                let (fixed, warped) = (
                    rms_error(t, template(b)),
                    warped_rms_error(t, template(b), WARP_BAND),
                );
                assert!(warped <= fixed + 1e-12, "{a} vs {b}: {warped} > {fixed}");
                // No band: the fixed pairing itself.
                assert!((warped_rms_error(t, template(b), 0) - fixed).abs() < 1e-12);
            }
        }
        assert_eq!(
            warped_rms_error(&[], template(Action::ALL[0]), 8),
            f64::INFINITY
        );
    }

    #[test]
    fn templates_stay_apart_under_warping() {
        // The smallest distance between two templates, warped, must stay well above the
        // receivers' runner-up margins and near the fixed pairing's (START vs END 0.41).
        let mut closest = f64::INFINITY;
        for a in Action::ALL {
            for b in Action::ALL.into_iter().filter(|&b| b != a) {
                let warped = warped_rms_error(template(a), template(b), WARP_BAND);
                eprintln!(
                    "{a} vs {b}: fixed {:.3}, warped {warped:.3}",
                    rms_error(template(a), template(b))
                );
                closest = closest.min(warped);
            }
        }
        assert!(
            closest > 0.3,
            "closest templates {closest:.3} apart when warped"
        );
    }

    #[test]
    fn samples_slid_along_the_shape_cost_little_when_warped() {
        // A stroke flown with a wobble on its first half: the extra arc length there slides
        // every later sample along the shape. The shape itself is right.
        for a in Action::ALL {
            let clean = drawn(a, 90.0, [320.0, 240.0], 8);
            let span = largest_span(&clean);
            let dense = resample_arc_length(&clean, 400);
            let wobbly: Vec<[f64; 2]> = dense
                .iter()
                .enumerate()
                .map(|(i, p)| {
                    let w = if i < 200 {
                        0.02 * span * (i as f64 * 0.9).sin()
                    } else {
                        0.0
                    };
                    [p[0] + w, p[1] - w]
                })
                .collect();
            let u = normalise(&resample_arc_length(&wobbly, RESAMPLE_POINTS));
            let (fixed, warped) = (
                rms_error(&u, template(a)),
                warped_rms_error(&u, template(a), WARP_BAND),
            );
            assert!(
                warped < 0.8 * fixed,
                "{a}: warped {warped:.3}, fixed {fixed:.3}"
            );
            assert_eq!(
                classify(&wobbly, &MatchSettings::rgb()).map(|c| c.action),
                Ok(a)
            );
        }
    }

    #[test]
    fn resampling_is_arc_length_uniform_and_keeps_endpoints() {
        let path = [[0.0, 0.0], [10.0, 0.0], [10.0, 30.0]];
        let r = resample_arc_length(&path, 5);
        assert_eq!(
            r,
            vec![
                [0.0, 0.0],
                [10.0, 0.0],
                [10.0, 10.0],
                [10.0, 20.0],
                [10.0, 30.0]
            ]
        );
        assert_eq!(resample_arc_length(&[[1.0, 2.0]], 3), vec![[1.0, 2.0]; 3]);
        assert!(resample_arc_length(&[], 80).is_empty());
    }

    #[test]
    fn normalise_divides_by_the_largest_span_only() {
        let n = normalise(&[[5.0, 5.0], [5.0, 45.0], [5.0, 25.0]]);
        assert_eq!(n, vec![[0.0, -0.5], [0.0, 0.5], [0.0, 0.0]]);
        assert_eq!(normalise(&[[3.0, 3.0], [3.0, 3.0]]), vec![[0.0, 0.0]; 2]);
    }

    #[test]
    fn rejections_name_the_failed_test() {
        let s = MatchSettings::rgb();
        let short = drawn(Action::Bit0, 90.0, [300.0, 200.0], 3);
        assert_eq!(short.len(), 10);
        assert!(matches!(
            classify(&short, &s),
            Err(Rejection::TooFewPoints {
                points: 10,
                min: 12
            })
        ));
        let tiny = drawn(Action::Bit0, 20.0, [300.0, 200.0], 8);
        assert!(matches!(
            classify(&tiny, &s),
            Err(Rejection::TooSmallSpan { .. })
        ));
        // An open stroke: only the first half of the V.
        let open: Vec<_> = (0..20)
            .map(|i| [300.0 + 3.0 * i as f64, 200.0 + 5.0 * i as f64])
            .collect();
        assert!(matches!(
            classify(&open, &s),
            Err(Rejection::NotClosed { .. })
        ));
        // A closed square loop resembles no template.
        let mut square = Vec::new();
        for i in 0..10 {
            square.push([100.0 + 10.0 * i as f64, 100.0]);
        }
        for i in 0..10 {
            square.push([200.0, 100.0 + 10.0 * i as f64]);
        }
        for i in 0..10 {
            square.push([200.0 - 10.0 * i as f64, 200.0]);
        }
        for i in 0..=10 {
            square.push([100.0, 200.0 - 10.0 * i as f64]);
        }
        assert!(
            matches!(
                classify(&square, &s),
                Err(Rejection::NoTemplateClose { .. })
            ),
            "{:?}",
            classify(&square, &s)
        );
        let mut nan = drawn(Action::End, 90.0, [300.0, 200.0], 8);
        nan[4][1] = f64::NAN;
        assert_eq!(classify(&nan, &s), Err(Rejection::NonFinite));
    }

    #[test]
    fn a_path_halfway_between_v_and_inverted_v_is_ambiguous() {
        // A closed triangle whose apex sits on the base line is a flat back-and-forth stroke,
        // equally far from bit 0 and bit 1; with a tiny apex it must not be forced to either.
        let s = MatchSettings {
            error_limit: 10.0,
            ..MatchSettings::rgb()
        };
        let path: Vec<_> = (0..=40)
            .map(|i| {
                [
                    100.0 + (if i <= 20 { i } else { 40 - i }) as f64 * 5.0,
                    100.0,
                ]
            })
            .collect();
        match classify(&path, &s) {
            Err(Rejection::Ambiguous {
                best, runner_up, ..
            }) => assert_ne!(best, runner_up),
            other => panic!("expected ambiguity, got {other:?}"),
        }
    }

    proptest! {
        #[test]
        fn scaled_translated_copies_classify_the_same(
            a in action_strategy(),
            scale in 30.0f64..400.0,
            ox in -1000.0f64..1000.0,
            oy in -1000.0f64..1000.0,
            per_segment in 4usize..20,
        ) {
            let reference = classify(&drawn(a, 90.0, [320.0, 240.0], 8), &MatchSettings::rgb()).unwrap();
            let c = classify(&drawn(a, scale, [ox, oy], per_segment), &MatchSettings::rgb()).unwrap();
            prop_assert_eq!(c.action, reference.action);
            prop_assert!(c.error < 1e-6);
        }
    }

    proptest! {
        // Independent per-point noise has a thin tail that grows with sampling density (the
        // jitter inflates arc length): on 100 000 random paths, none exceeded the RGB limit at
        // ≤ 6 points per segment, ~1e-5 did at 8 and ~1e-4 at 11 (adversarial shrinking finds
        // 0.20 there). The fixed seed keeps this property test reproducible.
        #![proptest_config(ProptestConfig {
            cases: 1024,
            rng_seed: proptest::test_runner::RngSeed::Fixed(0x5741_4747_4C45),
            ..ProptestConfig::default()
        })]

        #[test]
        fn five_percent_noise_still_classifies_correctly(
            a in action_strategy(),
            scale in 40.0f64..300.0,
            noise in prop::collection::vec((0.0f64..=1.0, 0.0f64..std::f64::consts::TAU), 64..=64),
            per_segment in 4usize..=8,
        ) {
            // Independent noise on every point, anywhere within 5 % of the span (a disc), on
            // paths of 13–41 points (a 25 Hz track of a 0.5–1.6 s action).
            let mut path = drawn(a, scale, [320.0, 240.0], per_segment);
            let span = largest_span(&path);
            for (p, &(r, phi)) in path.iter_mut().zip(&noise) {
                p[0] += 0.05 * span * r.sqrt() * phi.cos();
                p[1] += 0.05 * span * r.sqrt() * phi.sin();
            }
            for settings in [MatchSettings::rgb(), MatchSettings::events()] {
                let c = classify(&path, &settings);
                prop_assert!(matches!(c, Ok(ref c) if c.action == a), "{:?}: {:?}", a, c);
            }
        }
    }
}
