//! The gesture set: how large and how long each motion symbol is flown, and the NULL holds.
//!
//! Shapes come from [`Action::keypoints`] (performer-view units: `u` right, `v` up as seen by
//! every observer). The performer flies them in the world x–z plane: `u` → world +x, `v` → world
//! +z, which is the plane all observers face (world +x appears to the right in every observer's
//! image, see [`crate::scene`]).
//!
//! # Default timing and why
//!
//! | item | value | reason |
//! | --- | --- | --- |
//! | lead NULL of an offer | 6.0 s | the event acquisition quiet is 6 s and serves as the first NULL; the same value in RGB lets a receiver reset at offer start still confirm it (3 s) with margin |
//! | NULL between symbols / final NULL | 5.0 s | 3 s confirmation + 2 s margin for the vehicle to settle and for a receiver's anchor to form after the deceleration |
//! | NULL shared by back-to-back offers | 6.0 s | the parser keeps the releasing NULL as the next frame's first NULL, so one hover separates two offers |
//! | START, END | 8.0 s (5 strokes) | two up–down (left–right) cycles |
//! | bit 0, bit 1 | 6.0 s (3 strokes) | |
//! | acquisition sweep | 4.0 s | one left–right–centre sweep (events only), followed by the 6 s lead NULL |
//!
//! One offer therefore lasts 6 + 8 + 6·6 + 7·5 + 8 + 5 = 98 s of schedule, and a receiver
//! confirms its final NULL ≈ 2.6–2.8 s into the final 5 s hold (its rest anchor forms during the
//! deceleration): measured on the ideal receiver at 25 Hz, 95.56–95.72 s from offer start to
//! final NULL (paper: 95.52–95.64 s). Stroke times within a symbol are proportional to
//! √(stroke length), which equalises the peak acceleration of all strokes of a symbol.
//!
//! Amplitudes: 0.15 m for START (vertical), END and the acquisition sweep (horizontal), and for
//! the bits' depth; the bits are 0.175 m wide. Side observers (±40° for N = 3) see world x
//! foreshortened by ≈ 0.77 and the normalised template error grows quickly with aspect
//! distortion, so the width splits the distortion between the centre observer (V too wide) and
//! the side ones (too narrow): measured on the ideal receiver (25 Hz setpoints), the bits'
//! template error is ≤ 0.10 for every observer of N = 1…3 (0.15 m wide: 0.01 centre but 0.14 at
//! O1; 0.20 m: 0.16 centre), with the paper's first-point alignment; the centroid alignment of
//! [`crate::alphabet`] (the best translation) can only lower each of them. At f ≈ 579 px and
//! 1.26 m, 0.15 m ≈ 69 px, so every image path spans ≥ 66 px (limit: 28 px).
//!
//! The acquisition sweep matches no template (END error 0.41), so a receiver that happens to
//! hold a NULL before it reports `Unknown`, never a frame symbol.

use crate::Action;

use crate::scene::distance_m;
use crate::schedule::ScheduleError;

/// Nanoseconds per second.
pub const NS_PER_S: u64 = 1_000_000_000;
/// Nanoseconds per millisecond.
pub const NS_PER_MS: u64 = 1_000_000;

/// Keypoints of the event-acquisition sweep: one left–right pass returning to the centre. Kept
/// distinct from END (two full cycles) so it is never mistaken for a frame symbol by design.
pub const ACQUISITION_KEYPOINTS: [[f64; 2]; 4] = [[0.0, 0.0], [1.0, 0.0], [-1.0, 0.0], [0.0, 0.0]];

/// Size and duration of one flown polyline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionProfile {
    /// World metres per keypoint unit along `u` (world +x).
    pub amplitude_u_m: f64,
    /// World metres per keypoint unit along `v` (world +z).
    pub amplitude_v_m: f64,
    /// Total duration of the polyline, all strokes.
    pub duration_ns: u64,
}

/// Every size and duration the schedule builder uses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GestureConfig {
    /// Profiles indexed like [`Action::ALL`] (START, bit 0, bit 1, END).
    pub actions: [MotionProfile; 4],
    /// The event-modality acquisition sweep.
    pub acquisition: MotionProfile,
    /// First NULL of an offer (also the 6 s quiet after the acquisition sweep).
    pub lead_null_ns: u64,
    /// NULL between two symbols of an offer.
    pub null_hold_ns: u64,
    /// Last NULL of a broadcast.
    pub final_null_ns: u64,
    /// NULL separating two back-to-back offers (final NULL of one, first NULL of the next).
    pub shared_null_ns: u64,
}

impl Default for GestureConfig {
    fn default() -> Self {
        let symbol = |u: f64, v: f64, ms: u64| MotionProfile {
            amplitude_u_m: u,
            amplitude_v_m: v,
            duration_ns: ms * NS_PER_MS,
        };
        Self {
            actions: [
                symbol(0.15, 0.15, 8_000),
                symbol(0.175, 0.15, 6_000),
                symbol(0.175, 0.15, 6_000),
                symbol(0.15, 0.15, 8_000),
            ],
            acquisition: symbol(0.15, 0.15, 4_000),
            lead_null_ns: 6 * NS_PER_S,
            null_hold_ns: 5 * NS_PER_S,
            final_null_ns: 5 * NS_PER_S,
            shared_null_ns: 6 * NS_PER_S,
        }
    }
}

impl GestureConfig {
    /// The profile of `action`.
    pub fn profile(&self, action: Action) -> MotionProfile {
        self.actions[action.index()]
    }

    /// Rejects non-finite or non-positive amplitudes and zero durations.
    pub fn validate(&self) -> Result<(), ScheduleError> {
        for p in self.actions.iter().chain([&self.acquisition]) {
            let usable = |a: f64| a.is_finite() && a > 0.0;
            if !usable(p.amplitude_u_m) || !usable(p.amplitude_v_m) {
                return Err(ScheduleError::BadAmplitude {
                    amplitude_u_m: p.amplitude_u_m,
                    amplitude_v_m: p.amplitude_v_m,
                });
            }
            if p.duration_ns == 0 {
                return Err(ScheduleError::ZeroDuration);
            }
        }
        if [
            self.lead_null_ns,
            self.null_hold_ns,
            self.final_null_ns,
            self.shared_null_ns,
        ]
        .contains(&0)
        {
            return Err(ScheduleError::ZeroDuration);
        }
        Ok(())
    }
}

/// One straight minimum-jerk stroke of a polyline, relative to the polyline's origin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stroke {
    pub from_m: [f64; 3],
    pub to_m: [f64; 3],
    pub duration_ns: u64,
}

/// The strokes of `keypoints` flown with `profile` around `origin_m`.
///
/// Stroke durations are proportional to √(stroke length) — for minimum-jerk strokes that makes
/// every stroke's peak acceleration equal — and sum exactly to `profile.duration_ns` (the last
/// stroke absorbs the integer rounding). Zero-length strokes are dropped.
pub fn strokes(keypoints: &[[f64; 2]], profile: &MotionProfile, origin_m: [f64; 3]) -> Vec<Stroke> {
    let world = |k: [f64; 2]| {
        [
            origin_m[0] + k[0] * profile.amplitude_u_m,
            origin_m[1],
            origin_m[2] + k[1] * profile.amplitude_v_m,
        ]
    };
    let legs: Vec<([f64; 3], [f64; 3], f64)> = keypoints
        .windows(2)
        .map(|w| {
            let (a, b) = (world(w[0]), world(w[1]));
            (a, b, distance_m(a, b))
        })
        .filter(|&(_, _, len)| len > 0.0)
        .collect();
    let total_weight: f64 = legs.iter().map(|l| l.2.sqrt()).sum();
    let mut out = Vec::with_capacity(legs.len());
    let mut used_ns = 0u64;
    for (i, &(from_m, to_m, len)) in legs.iter().enumerate() {
        let duration_ns = if i + 1 == legs.len() {
            profile.duration_ns.saturating_sub(used_ns)
        } else {
            // Truncation keeps the running sum ≤ the total, so the last stroke is never negative.
            (profile.duration_ns as f64 * len.sqrt() / total_weight) as u64
        };
        used_ns += duration_ns;
        out.push(Stroke {
            from_m,
            to_m,
            duration_ns,
        });
    }
    out
}
