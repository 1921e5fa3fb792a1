//! A flight rendered once and kept (the render cache of `waggle trials`).
//!
//! Sensor perturbations do not change what the cameras see, only what the sensors make of it,
//! so every such trial of a condition replays the same renders: physics and rendering run once,
//! and each trial costs only its sensors and receivers. A render is stored as what changed since
//! the camera's previous render (the damage rectangle's pixels, nothing, or the whole frame), so
//! a 30 s flight of three observers at 100 Hz keeps a few tens of MB, not gigabytes.
//!
//! That holds only while the cameras stand still. A flight that moves them (the cascade's noisy
//! estimate, wind) changes every pixel of every render, so each render would be kept whole
//! (0.9 MB, gigabytes a flight): such a flight is flown once per trial anyway, so its renders
//! are streamed to their consumer as they are made ([`fly_streamed`]) and never kept.

use std::collections::BTreeMap;

use anyhow::{Context, Result};
use evaluation::IdealReceiver;
use proto::scene::{Formation, ObserverCamera, distance_m};
use proto::{
    EgoRotation, FrameChange, Modality, PixelRect, Rectification, RenderPath, Schedule,
    SegmenterConfig,
};
use rand_distr::{Distribution, Normal};
use sim::render::CameraRenderer;
use sim::world::World;

use crate::harness::flight::air::{Tracking, tracking_of};
use crate::harness::flight::performer::step_along;
use crate::harness::link::{IDEAL_PERIOD_NS, ObserverOut, observer_out};

/// The performer is drone 0.
const PERFORMER: usize = 0;

/// What to fly and render.
#[derive(Debug, Clone)]
pub struct FlightSpec {
    pub formation: Formation,
    pub schedule: Schedule,
    pub end_ns: u64,
    /// Time between renders (a multiple of the 2 ms physics step).
    pub render_period_ns: u64,
    pub render: RenderPath,
    pub rectification: Rectification,
    /// Gusts on the performer: σ of each horizontal component (N), how long each holds (ns),
    /// the seed of the draws. `None`: still air.
    pub gusts: Option<Gusts>,
    /// Wind and the cascade controller (`wind.*`, `flight.cascade`) with the trial's seed, set
    /// on the world before it flies ([`crate::harness::flight::air::set_air`]). `None`: still air and
    /// the paper's ideal stabilisation.
    pub air: Option<(perturb::Perturbation, u64)>,
}

/// A gust model: a horizontal force on the performer, redrawn at the first render at or after
/// each period.
#[derive(Debug, Clone, Copy)]
pub struct Gusts {
    pub sigma_n: f64,
    pub period_ns: u64,
    pub seed: u64,
}

/// One camera's stored render: its stamp and what changed since the previous one.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Update {
    pub(crate) stamp_ns: u64,
    pub(crate) change: FrameChange,
    /// The changed pixels: the rectangle's rows (`Within`), the whole frame (`All`), or none.
    pub(crate) pixels: Vec<u8>,
    /// How far the observer's airframe had turned from home when this was drawn.
    pub(crate) ego: Option<EgoRotation>,
}

/// Every render of one camera.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RenderTrack {
    pub(crate) frame_len: usize,
    pub(crate) width: usize,
    pub(crate) updates: Vec<Update>,
}

/// A flown and rendered broadcast, with the ideal receiver's decodes of the same flight.
#[derive(Debug, Clone)]
pub struct RenderedFlight {
    pub spec: FlightSpec,
    pub tracks: Vec<RenderTrack>,
    /// The ideal receiver's tokens and frames per observer, with each modality's segmenter
    /// timing (the reference its trials are compared with).
    pub ideal: BTreeMap<Modality, Vec<ObserverOut>>,
    pub sim_ns: u64,
    pub performer_max_tracking_error_m: f64,
    pub contact_steps: u64,
}

impl RenderTrack {
    /// Keeps a render ([`fly_streamed`] hands a camera's first render over as `All`).
    fn push(
        &mut self,
        stamp_ns: u64,
        rgb: &[u8],
        change: FrameChange,
        width: usize,
        ego: Option<EgoRotation>,
    ) {
        debug_assert!(!self.updates.is_empty() || change == FrameChange::All);
        let pixels = match change {
            FrameChange::Nothing => Vec::new(),
            FrameChange::All => rgb.to_vec(),
            FrameChange::Within(r) => {
                let mut out = Vec::with_capacity(r.area_px() * 3);
                for (start, end) in rows(r, width) {
                    out.extend_from_slice(&rgb[start..end]);
                }
                out
            }
        };
        self.frame_len = rgb.len();
        self.width = width;
        self.updates.push(Update {
            stamp_ns,
            change,
            pixels,
            ego,
        });
    }

    /// Whether any render was drawn from a turned airframe.
    pub(crate) fn turned(&self) -> bool {
        self.updates.iter().any(|u| u.ego.is_some())
    }

    /// Bytes held.
    pub fn stored_bytes(&self) -> usize {
        self.updates.iter().map(|u| u.pixels.len()).sum()
    }

    /// Replays the renders in order: `visit(stamp_ns, whole frame, change since previous, how
    /// far the airframe had turned)`.
    pub fn replay(
        &self,
        mut visit: impl FnMut(u64, &[u8], FrameChange, Option<EgoRotation>) -> Result<bool>,
    ) -> Result<()> {
        let mut frame = vec![0u8; self.frame_len];
        for u in &self.updates {
            match u.change {
                FrameChange::Nothing => {}
                FrameChange::All => frame.copy_from_slice(&u.pixels),
                FrameChange::Within(r) => {
                    let mut at = 0;
                    for (start, end) in rows(r, self.width) {
                        frame[start..end].copy_from_slice(&u.pixels[at..at + end - start]);
                        at += end - start;
                    }
                }
            }
            if !visit(u.stamp_ns, &frame, u.change, u.ego)? {
                break;
            }
        }
        Ok(())
    }
}

/// Byte ranges of the rows of `r` in a frame `width` pixels wide.
fn rows(r: PixelRect, width: usize) -> impl Iterator<Item = (usize, usize)> {
    let (x, w) = (usize::from(r.x), usize::from(r.width));
    (usize::from(r.y)..usize::from(r.y) + usize::from(r.height)).map(move |y| {
        let start = 3 * (y * width + x);
        (start, start + 3 * w)
    })
}

/// What a flight gave besides its renders.
#[derive(Debug, Clone)]
pub struct Flown {
    /// The ideal receiver's tokens and frames per observer, for each modality's segmenter.
    pub ideal: BTreeMap<Modality, Vec<ObserverOut>>,
    pub sim_ns: u64,
    pub performer_max_tracking_error_m: f64,
    /// The performer's tracking of its reference over the flight (RMS and max).
    pub performer_tracking: Tracking,
    pub contact_steps: u64,
}

/// Flies `spec` once and keeps every observer's renders (the render cache).
pub fn fly_rendered(spec: FlightSpec) -> Result<RenderedFlight> {
    let width = usize::from(proto::scene::IMAGE_WIDTH_PX);
    let mut tracks = vec![RenderTrack::default(); spec.formation.len()];
    let flown = fly_streamed(&spec, |i, t, rgb, change, pose| {
        tracks[i].push(t, rgb, change, width, pose.ego);
        Ok(true)
    })?
    .context("a render cache never stops its flight")?;
    Ok(RenderedFlight {
        tracks,
        ideal: flown.ideal,
        sim_ns: flown.sim_ns,
        performer_max_tracking_error_m: flown.performer_max_tracking_error_m,
        contact_steps: flown.contact_steps,
        spec,
    })
}

/// Where things were when a camera rendered: the truth beside each render.
#[derive(Debug, Clone, Copy)]
pub struct RenderPose {
    /// How far the airframe had turned from home (`None`: not turned, to the last bit).
    pub ego: Option<EgoRotation>,
    /// How far the airframe had moved from home, m (world axes).
    pub shift_m: [f64; 3],
    /// The performer's centre, m (world axes).
    pub performer_m: [f64; 3],
}

impl RenderPose {
    /// Where the performer's centre appears in the image `home`'s camera made at this pose:
    /// turned by the airframe's turn and moved with it (the camera's 4 cm lever arm is not
    /// turned: 0.35 mm at a 0.5° lean). `None` behind the camera or outside the image.
    pub fn performer_px(&self, home: &ObserverCamera) -> Option<[f64; 2]> {
        let mut camera = *home;
        for (c, s) in camera.world_pos_m.iter_mut().zip(self.shift_m) {
            *c += s;
        }
        let p = match &self.ego {
            Some(ego) => proto::stabilise::turned_px(&camera, ego, self.performer_m)?,
            None => camera.project_px(self.performer_m)?,
        };
        let inside = (0.0..f64::from(proto::scene::IMAGE_WIDTH_PX)).contains(&p[0])
            && (0.0..f64::from(proto::scene::IMAGE_HEIGHT_PX)).contains(&p[1]);
        inside.then_some(p)
    }
}

/// Flies `spec` once, rendering every observer's camera at `render_period_ns` and handing each
/// render to `visit(observer, stamp_ns, whole frame, change since that camera's previous
/// render, pose)` as it is made, observers in order at each instant — what
/// [`RenderTrack::replay`] gives for the same flight (a camera's first render is `All`). The
/// pose's turn is the attitude the render was drawn at. Nothing is kept. `None` when `visit`
/// returns `false` (the flight stops there).
pub fn fly_streamed(
    spec: &FlightSpec,
    mut visit: impl FnMut(usize, u64, &[u8], FrameChange, RenderPose) -> Result<bool>,
) -> Result<Option<Flown>> {
    let mut world = World::with_formation(&spec.formation).context("building the scene")?;
    // Observer i is drone i + 1; its home attitude is the one the scene was built with.
    let homes: Vec<([f64; 3], [f64; 4])> = (0..spec.formation.len())
        .map(|i| world.body_pose(i + 1))
        .collect();
    if let Some((p, seed)) = &spec.air {
        crate::harness::flight::air::set_air(&mut world, p, *seed)?;
    }
    let mut renderer =
        CameraRenderer::new(&world, spec.render).context("creating the offscreen renderer")?;
    let mut ideal = Modality::ALL
        .iter()
        .map(|&m| {
            let config = SegmenterConfig::for_modality(m);
            IdealReceiver::with_formation(&spec.formation, config, spec.rectification).map(
                |mut r| {
                    r.set_frame_check(spec.schedule.frame_check());
                    (m, r)
                },
            )
        })
        .collect::<Result<Vec<_>, _>>()?;
    // Whether each camera has rendered yet (its first render is handed over whole).
    let mut seen = vec![false; spec.formation.len()];
    let mut gust = spec.gusts.map(|g| {
        use rand::SeedableRng;
        (g, rand_chacha::ChaCha8Rng::seed_from_u64(g.seed), 0u64)
    });
    let mut max_err_m: f64 = 0.0;
    while world.time_ns() < spec.end_ns {
        step_along(&mut world, &spec.schedule);
        let t = world.time_ns();
        max_err_m = max_err_m.max(distance_m(
            spec.schedule.setpoint_at(t),
            world.position_m(PERFORMER),
        ));
        if t.is_multiple_of(IDEAL_PERIOD_NS) {
            for (_, receiver) in &mut ideal {
                receiver.push(t, world.position_m(PERFORMER))?;
            }
        }
        if !t.is_multiple_of(spec.render_period_ns) {
            continue;
        }
        if let Some((g, rng, next_ns)) = gust.as_mut()
            && t >= *next_ns
        {
            let normal = Normal::new(0.0, g.sigma_n).context("gust σ")?;
            let force = [normal.sample(rng), normal.sample(rng), 0.0];
            world.set_disturbance_n(PERFORMER, force);
            *next_ns = t + g.period_ns;
        }
        let performer_m = world.position_m(PERFORMER);
        for (i, seen) in seen.iter_mut().enumerate() {
            let (position_m, attitude) = world.body_pose(i + 1);
            let pose = RenderPose {
                ego: EgoRotation::between(homes[i].1, attitude),
                shift_m: std::array::from_fn(|k| position_m[k] - homes[i].0[k]),
                performer_m,
            };
            let frame = renderer.render_change(&mut world, i)?;
            let change = if *seen {
                frame.change
            } else {
                FrameChange::All
            };
            *seen = true;
            if !visit(i, t, frame.rgb, change, pose)? {
                return Ok(None);
            }
        }
    }
    let ideal = ideal
        .iter()
        .map(|(m, receiver)| {
            let outs = receiver
                .outputs()
                .iter()
                .map(|o| observer_out(&o.tokens, &o.frames))
                .collect();
            (*m, outs)
        })
        .collect();
    Ok(Some(Flown {
        ideal,
        sim_ns: world.time_ns(),
        performer_max_tracking_error_m: max_err_m,
        performer_tracking: tracking_of(&world, PERFORMER),
        contact_steps: world.contact_stats().contact_steps,
    }))
}

impl RenderedFlight {
    /// Bytes held by every track.
    pub fn stored_bytes(&self) -> usize {
        self.tracks.iter().map(RenderTrack::stored_bytes).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::RenderPose;
    use proto::scene::Placement;
    use proto::stabilise::{EgoRotation, about, product, turned_px};

    /// The label is where the performer is in the image the camera made: unturned and unmoved
    /// it is the home camera's projection; turned, the turned camera's; moved, the moved one's.
    #[test]
    fn the_performer_is_placed_in_the_image_the_turned_and_moved_camera_made() {
        let placement = Placement::viewpoint(20.0, 0.0, 1.5);
        let home = placement.camera();
        let performer_m = proto::scene::PERFORMER_HOVER_M;
        let still = RenderPose {
            ego: None,
            shift_m: [0.0; 3],
            performer_m,
        };
        assert_eq!(still.performer_px(&home), home.project_px(performer_m));

        let home_q = about([0.0, 0.0, 1.0], placement.yaw_rad);
        let ego = EgoRotation::between(home_q, product(about([0.3, 1.0, 0.1], 0.05), home_q));
        let turned = RenderPose { ego, ..still };
        let expected = turned_px(&home, ego.as_ref().unwrap(), performer_m).unwrap();
        assert_eq!(turned.performer_px(&home), Some(expected));
        let moved_by_px = {
            let p = turned.performer_px(&home).unwrap();
            let q = still.performer_px(&home).unwrap();
            (p[0] - q[0]).hypot(p[1] - q[1])
        };
        // 0.05 rad, mostly across the optical axis.
        assert!(
            moved_by_px > 0.5 * 0.05 * proto::scene::focal_px(),
            "{moved_by_px}"
        );

        // Moving the camera 5 cm towards the performer's right moves its image left.
        let right = [-placement.yaw_rad.sin(), placement.yaw_rad.cos(), 0.0];
        let moved = RenderPose {
            shift_m: [0.05 * -right[0], 0.05 * -right[1], 0.0],
            ..still
        };
        let (p, q) = (
            moved.performer_px(&home).unwrap(),
            still.performer_px(&home).unwrap(),
        );
        assert!((p[0] - q[0]).abs() > 10.0, "{p:?} against {q:?}");
        assert!((p[1] - q[1]).abs() < 1.0, "{p:?} against {q:?}");
    }
}
