//! Seeded repeated trials of one condition (`waggle trials`): a broadcast flown and rendered,
//! decoded by every observer under a perturbation drawn from each trial's seed.
//!
//! Sensor and link perturbations share one [`RenderedFlight`] (matched trajectories: trials
//! differ only by the perturbation); placement jitter and gusts fly each trial anew. The success
//! criterion is fixed before the first trial: every observer releases exactly the broadcast
//! payloads, in order. Everything a trial records is a function of the condition and its seed
//! (no wall-clock value), so the same seed gives identical records whatever `--jobs`.

pub use crate::harness::trials_out::{
    ObserverTrial, PlacementOut, TokenTiming, TrialRecord, TrialsCost, TrialsHeader, TrialsOut,
    TrialsSummary,
};
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::{Context, Result, bail};
use event_camera::{CameraConfig, EventCamera};
use perception::perception::{Perception, SensorInput};
use perturb::Perturbation;
use perturb::seed::{Stream, rng, stream_seed, trial_seed};
use proto::scene::{
    Formation, IMAGE_HEIGHT_PX, IMAGE_WIDTH_PX, MAX_OBSERVERS, Placement, observer_name,
};
use proto::{Modality, Rectification, RenderPath, RgbFrame};
use rand_distr::{Distribution, Normal};
use sim::sensor::{EVENT_RENDER_PERIOD_NS, RGB_PERIOD_NS};

use crate::harness::link::{ObserverOut, bits6, broadcast_schedule, observer_out};
use crate::harness::pool::run_pool_on;
use crate::harness::rendered_flight::{FlightSpec, Gusts, RenderedFlight, fly_rendered};

/// One condition and how many times to try it.
#[derive(Debug, Clone)]
pub struct TrialsOptions {
    /// The broadcast payloads (six bits each), flown back to back.
    pub payloads: Vec<u8>,
    /// The observers' nominal placements.
    pub formation: Formation,
    pub modality: Modality,
    pub trials: u64,
    pub seed: u64,
    pub perturbation: Perturbation,
    /// Trials run at once (threads).
    pub jobs: usize,
    pub render: RenderPath,
    pub rectification: Rectification,
    /// Fly the acquisition sweep before the first offer (`None`: only for event cameras, as
    /// the paper and `waggle link` do). A study of both modalities flies it for both, so their
    /// trials see one flight.
    pub acquisition: Option<bool>,
}

/// What one observer's receiver made of a trial's sensor stream.
struct Observed {
    out: ObserverOut,
    messages: u64,
    lost: u64,
    denoise: Option<perception::events::DenoiseCounts>,
}

impl TrialsOptions {
    /// Checks the condition before anything runs.
    pub fn check(&self) -> Result<()> {
        if self.payloads.is_empty() {
            bail!("--link needs at least one six-bit payload");
        }
        if self.trials == 0 {
            bail!("--trials must be at least 1");
        }
        if self.formation.len() > MAX_OBSERVERS {
            bail!("at most {MAX_OBSERVERS} observers");
        }
        Ok(())
    }

    fn want(&self) -> Vec<String> {
        self.payloads.iter().map(|&p| bits6(p)).collect()
    }

    /// How often this condition's sensors need a render.
    pub fn render_period_ns(&self) -> u64 {
        match self.modality {
            Modality::Events => EVENT_RENDER_PERIOD_NS,
            Modality::Rgb if self.perturbation.rgb().blur_renders > 1 => EVENT_RENDER_PERIOD_NS,
            Modality::Rgb => RGB_PERIOD_NS,
        }
    }

    /// One flight for trials of several options on this formation and broadcast (the points
    /// of one study level), rendered every `render_period_ns` (the shortest any of them needs:
    /// RGB takes every fourth render of an event-rate flight).
    pub fn shared_flight_spec(&self, render_period_ns: u64) -> Result<FlightSpec> {
        let mut spec = self.flight_spec(None)?;
        spec.render_period_ns = render_period_ns;
        Ok(spec)
    }

    /// The flight of trial `seed` (the nominal one when nothing re-flies).
    fn flight_spec(&self, seed: Option<u64>) -> Result<FlightSpec> {
        let acquisition = self
            .acquisition
            .unwrap_or(self.modality == Modality::Events);
        let (schedule, end_ns) = broadcast_schedule(&self.payloads, acquisition, 0)?;
        let mut formation = self.formation.clone();
        let mut gusts = None;
        let mut air = None;
        if let Some(seed) = seed {
            if self.perturbation.wind().is_some() || self.perturbation.cascade().is_some() {
                air = Some((self.perturbation.clone(), seed));
            }
            formation = jittered(&self.formation, &self.perturbation, seed)?;
            let sigma_n = self.perturbation.gust_sigma_n();
            if sigma_n > 0.0 {
                gusts = Some(Gusts {
                    sigma_n,
                    period_ns: self.perturbation.gust_period_ns(),
                    seed: stream_seed(seed, Stream::Gust, 0),
                });
            }
        }
        Ok(FlightSpec {
            formation,
            schedule,
            end_ns,
            render_period_ns: self.render_period_ns(),
            render: self.render,

            rectification: self.rectification,
            gusts,
            air,
        })
    }
}

/// `formation` with each observer's home and heading jittered by the trial's placement draws.
fn jittered(formation: &Formation, p: &Perturbation, seed: u64) -> Result<Formation> {
    let (sigma_m, sigma_yaw_rad) = p.placement_sigma();
    if sigma_m == 0.0 && sigma_yaw_rad == 0.0 {
        return Ok(formation.clone());
    }
    let placements: Vec<Placement> = formation
        .placements()
        .iter()
        .enumerate()
        .map(|(i, nominal)| {
            let mut r = rng(seed, Stream::Placement, i);
            let mut draw = |sigma: f64| Normal::new(0.0, sigma).map_or(0.0, |n| n.sample(&mut r));
            let h = nominal.home_m;
            let home = [
                h[0] + draw(sigma_m),
                h[1] + draw(sigma_m),
                h[2] + draw(sigma_m),
            ];
            let mut placed = Placement::aimed_from(home);
            placed.yaw_rad += draw(sigma_yaw_rad);
            placed
        })
        .collect();
    Formation::custom(placements)
        .context("a jittered formation is not flyable (lower geometry.position_sigma_m)")
}

/// Pairs each ideal token with the nearest unused token of the same kind within ±1 s.
fn token_timing(ideal: &ObserverOut, got: &ObserverOut) -> TokenTiming {
    const WINDOW_S: f64 = 1.0;
    let mut used = vec![false; got.tokens.len()];
    let mut errors_ms = Vec::new();
    for t in &ideal.tokens {
        let best = got
            .tokens
            .iter()
            .enumerate()
            .filter(|(k, g)| !used[*k] && g.token == t.token && (g.t_s - t.t_s).abs() <= WINDOW_S)
            .min_by(|a, b| {
                let (da, db) = ((a.1.t_s - t.t_s).abs(), (b.1.t_s - t.t_s).abs());
                da.total_cmp(&db).then(a.0.cmp(&b.0))
            });
        if let Some((k, g)) = best {
            used[k] = true;
            errors_ms.push((g.t_s - t.t_s) * 1e3);
        }
    }
    let matched = errors_ms.len();
    let abs: Vec<f64> = errors_ms.iter().map(|e| e.abs()).collect();
    TokenTiming {
        matched,
        missed: ideal.tokens.len() - matched,
        extra: got.tokens.len() - matched,
        mean_abs_error_ms: (matched > 0).then(|| abs.iter().sum::<f64>() / matched as f64),
        max_abs_error_ms: abs.iter().copied().reduce(f64::max),
    }
}

/// One observer's receiver fed its perturbed sensor from the flight's renders. `None` when
/// `stop` was raised before it finished.
fn observe(
    flight: &RenderedFlight,
    i: usize,
    opts: &TrialsOptions,
    seed: u64,
    stop: &AtomicBool,
) -> Result<Option<Observed>> {
    let placement = flight.spec.formation.placements()[i];
    let mut perception =
        Perception::for_camera(opts.modality, placement.camera(), opts.rectification)?;
    let link = opts.perturbation.link();
    let mut link_rng = rng(seed, Stream::Link, i);
    let (mut tokens, mut frames) = (Vec::new(), Vec::new());
    let (mut messages, mut lost) = (0u64, 0u64);
    let mut deliver = |input: SensorInput<'_>, messages: &mut u64| -> Result<()> {
        *messages += 1;
        if !link.keeps(&mut link_rng) {
            lost += 1;
            return Ok(());
        }
        let step = perception.push(input)?;
        tokens.extend(step.tokens);
        frames.extend(step.frames);
        Ok(())
    };
    let mut finished = true;
    match opts.modality {
        Modality::Events => {
            let config = CameraConfig::paper(IMAGE_WIDTH_PX, IMAGE_HEIGHT_PX).with_model(
                opts.perturbation
                    .event_sensor(stream_seed(seed, Stream::EventSensor, i)),
            );
            let mut camera = EventCamera::new(config).context("event camera")?;
            flight.tracks[i].replay(|t, rgb, change| {
                if stop.load(Ordering::Relaxed) {
                    finished = false;
                    return Ok(false);
                }
                for packet in camera.push_frame_change(t, rgb, change)? {
                    deliver(SensorInput::Events(&packet), &mut messages)?;
                }
                Ok(true)
            })?;
        }
        Modality::Rgb => {
            let noise = opts.perturbation.rgb();
            let mut sensor = noise.sensor(&mut rng(seed, Stream::RgbSensor, i));
            let keep = noise.blur_renders.max(1) as usize;
            let mut recent: Vec<Vec<u8>> = Vec::new();
            let mut seq = 0u64;
            flight.tracks[i].replay(|t, rgb, _| {
                if stop.load(Ordering::Relaxed) {
                    finished = false;
                    return Ok(false);
                }
                if keep > 1 {
                    if recent.len() == keep {
                        recent.remove(0);
                    }
                    recent.push(rgb.to_vec());
                }
                if !t.is_multiple_of(RGB_PERIOD_NS) {
                    return Ok(true);
                }
                let renders: Vec<&[u8]> = if keep > 1 {
                    recent.iter().map(Vec::as_slice).collect()
                } else {
                    vec![rgb]
                };
                let frame = RgbFrame {
                    seq,
                    stamp_ns: t,
                    width: IMAGE_WIDTH_PX,
                    height: IMAGE_HEIGHT_PX,
                    valid: true,
                    continuous: true,
                    rgb: sensor.apply(&renders),
                };
                seq += 1;
                deliver(SensorInput::Rgb(&frame), &mut messages)?;
                Ok(true)
            })?;
        }
    }
    if !finished {
        return Ok(None);
    }
    let mut out = observer_out(&tokens, &frames);
    let delay_s = link.delay_ns() as f64 * 1e-9;
    for f in &mut out.frames {
        f.final_null_s += delay_s;
    }
    for t in &mut out.tokens {
        t.t_s += delay_s;
    }
    Ok(Some(Observed {
        out,
        messages,
        lost,
        denoise: perception.denoise_counts(),
    }))
}

/// Latency and comparison with the ideal receiver of each released frame.
fn release_times(
    flight: &RenderedFlight,
    ideal: &ObserverOut,
    got: &ObserverOut,
) -> (Vec<f64>, Vec<Option<f64>>) {
    let offers = flight.spec.schedule.offers();
    let mut latency = Vec::new();
    let mut vs_ideal = Vec::new();
    for f in &got.frames {
        let release_ns = (f.final_null_s * 1e9).round() as u64;
        // The offer this frame closes: the latest of its payload whose final NULL began before.
        let offer = offers
            .iter()
            .enumerate()
            .rfind(|(_, o)| bits6(o.payload) == f.payload && o.final_null_start_ns <= release_ns);
        if let Some((k, o)) = offer {
            latency.push((release_ns - o.final_null_start_ns) as f64 * 1e-9);
            let ideal_release = ideal.frames.iter().filter(|g| g.payload == f.payload).nth(
                offers[..k]
                    .iter()
                    .filter(|p| p.payload == o.payload)
                    .count(),
            );
            vs_ideal.push(ideal_release.map(|g| f.final_null_s - g.final_null_s));
        }
    }
    (latency, vs_ideal)
}

/// Runs trial `index` on `flight` (or its own flight when the perturbation re-flies).
fn run_trial(
    opts: &TrialsOptions,
    shared: Option<&RenderedFlight>,
    index: u64,
    stop: &AtomicBool,
) -> Result<Option<TrialRecord>> {
    let seed = trial_seed(opts.seed, index);
    let own;
    let flight = match shared {
        Some(f) => f,
        None => {
            own = fly_rendered(opts.flight_spec(Some(seed))?)?;
            &own
        }
    };
    let want = opts.want();
    let mut observers = BTreeMap::new();
    for i in 0..flight.spec.formation.len() {
        let Some(Observed {
            out,
            messages,
            lost: messages_lost,
            denoise,
        }) = observe(flight, i, opts, seed, stop)?
        else {
            return Ok(None);
        };
        let ideal = flight
            .ideal
            .get(&opts.modality)
            .and_then(|o| o.get(i))
            .context("the flight has no ideal receiver for this observer")?;
        let (latency_s, vs_ideal_s) = release_times(flight, ideal, &out);
        observers.insert(
            observer_name(i),
            ObserverTrial {
                success: out.payloads == want,
                released: out.payloads.clone(),
                release_s: out.frames.iter().map(|f| f.final_null_s).collect(),
                tokens: out.tokens.len(),
                token_timing: token_timing(ideal, &out),
                latency_s,
                vs_ideal_s,
                messages,
                messages_lost,
                events_received: denoise.map(|d| d.seen),
                events_removed: denoise.map(|d| d.removed),
            },
        );
    }
    Ok(Some(TrialRecord {
        index,
        seed,
        success: observers.values().all(|o| o.success),
        observers,
    }))
}

/// The criterion printed before the first trial and recorded in `trials.json`.
pub fn criterion(opts: &TrialsOptions) -> String {
    format!(
        "success = every observer ({}) releases exactly [{}], in order, and nothing else",
        opts.formation.len(),
        opts.want().join(", ")
    )
}

/// What [`run_trials`] did: the condition's header, the trials it finished (sorted by index)
/// and what they cost.
#[derive(Debug)]
pub struct TrialsRun {
    pub header: TrialsHeader,
    pub records: Vec<TrialRecord>,
    pub cost: TrialsCost,
}

/// Runs the trials `indices` (up to `opts.jobs` at once), calling `on_record` as each finishes
/// (from the thread that ran it: this is where a record is written) and then
/// `progress(done, successes)`. When `stop` is raised, running trials are abandoned and no
/// more start; the finished ones are returned. With no indices it only flies what the header
/// needs (the reference releases).
pub fn run_trials(
    opts: &TrialsOptions,
    flown: Option<&RenderedFlight>,
    indices: &[u64],
    stop: &AtomicBool,
    on_record: impl Fn(&TrialRecord) -> Result<()> + Sync,
    progress: impl Fn(u64, u64) + Sync,
) -> Result<TrialsRun> {
    opts.check()?;
    if let Some(&bad) = indices.iter().find(|&&i| i >= opts.trials) {
        bail!("trial {bad} is outside 0..{}", opts.trials);
    }
    let started = std::time::Instant::now();
    let own;
    let shared = match flown {
        _ if opts.perturbation.reflies() => None,
        Some(f) => {
            let need_ns = opts.render_period_ns();
            if !need_ns.is_multiple_of(f.spec.render_period_ns) {
                bail!(
                    "the shared flight renders every {} ms; {} trials need every {} ms",
                    f.spec.render_period_ns / 1_000_000,
                    opts.modality,
                    need_ns / 1_000_000
                );
            }
            Some(f)
        }
        None => {
            own = fly_rendered(opts.flight_spec(None)?)?;
            Some(&own)
        }
    };
    let fly_s = started.elapsed().as_secs_f64();
    // The reference: the unperturbed flight's ideal releases (flown here when trials re-fly).
    let nominal_ideal: Vec<ObserverOut> = match shared {
        Some(f) => f.ideal.get(&opts.modality).cloned().unwrap_or_default(),
        None => fly_rendered(opts.flight_spec(None)?)?
            .ideal
            .remove(&opts.modality)
            .unwrap_or_default(),
    };
    let trials_started = std::time::Instant::now();
    let records = run_pool_on(
        indices,
        opts.jobs,
        stop,
        |index| {
            let record = run_trial(opts, shared, index, stop)?;
            if let Some(r) = &record {
                on_record(r)?;
            }
            Ok(record)
        },
        progress,
    )?;
    let cost = TrialsCost {
        flights: if shared.is_some() {
            u64::from(flown.is_none())
        } else {
            records.len() as u64 + 1
        },
        fly_and_render_s: fly_s,
        trials_s: trials_started.elapsed().as_secs_f64(),
        render_cache_mb: shared
            .as_ref()
            .map_or(0.0, |f| f.stored_bytes() as f64 / 1e6),
    };
    let names: Vec<String> = (0..opts.formation.len()).map(observer_name).collect();
    let header = TrialsHeader {
        criterion: criterion(opts),
        link: opts.want(),
        observers: opts.formation.len(),
        placements: names
            .iter()
            .zip(opts.formation.placements())
            .map(|(n, p)| {
                let placement = PlacementOut {
                    home_m: p.home_m,
                    yaw_deg: p.yaw_rad.to_degrees(),
                    camera_pitch_deg: p.pitch_rad.to_degrees(),
                };
                (n.clone(), placement)
            })
            .collect(),
        modality: opts.modality.to_string(),
        perturb: opts.perturbation.recorded(),
        flight: if shared.is_some() {
            "shared"
        } else {
            "per trial"
        }
        .into(),
        seed: opts.seed,
        ideal_released: names
            .iter()
            .cloned()
            .zip(nominal_ideal.iter().map(|o| o.payloads.clone()))
            .collect(),
    };
    Ok(TrialsRun {
        header,
        records,
        cost,
    })
}

/// A fingerprint of everything that decides this condition's trials (not `jobs` nor the render
/// path, which give the same bytes): a run directory records it, and a rerun into the same
/// directory must match it.
pub fn definition(opts: &TrialsOptions) -> String {
    format!(
        "link {:?}; placements {:?}; modality {}; trials {}; seed {}; perturb {:?}; \
         rectification {:?}; acquisition {:?}",
        opts.want(),
        opts.formation.placements(),
        opts.modality,
        opts.trials,
        opts.seed,
        opts.perturbation.recorded(),
        opts.rectification,
        opts.acquisition
    )
}
