//! Seeded repeated trials of one condition (`waggle trials`): a broadcast flown and rendered,
//! decoded by every observer under a perturbation drawn from each trial's seed.
//!
//! Sensor and link perturbations share one [`RenderedFlight`] (matched trajectories: trials
//! differ only by the perturbation); placement jitter and gusts fly each trial anew. The success
//! criterion is fixed before the first trial: every observer releases exactly the broadcast
//! payloads, in order. Everything a trial records is a function of the condition and its seed
//! (no wall-clock value), so the same seed gives identical records whatever `--jobs`.
//!
//! Its parts: one trial's observers ([`observer`]), what `waggle trials` writes ([`out`]), the
//! thread pool trials run on ([`pool`]) and a trial's inputs handed out of the lab ([`tap`]).

pub mod observer;
pub mod out;
pub mod pool;
pub mod tap;

pub use crate::harness::trials::out::{
    ObserverTrial, PlacementOut, PluginFailure, RealNoiseOut, TokenTiming, TrialFlight,
    TrialRecord, TrialsCost, TrialsHeader, TrialsOut, TrialsSummary,
};
use std::collections::BTreeMap;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use anyhow::{Context, Result, bail};
use perturb::Perturbation;
use perturb::seed::{Stream, rng, stream_seed, trial_seed};
use proto::scene::{Formation, MAX_OBSERVERS, Placement, observer_name};
use proto::{Modality, Rectification, RenderPath, Schedule};
use rand_distr::{Distribution, Normal};
use receiver_plugin::{PluginError, PluginSpec, WorkerPool};
use sim::sensor::{EVENT_RENDER_PERIOD_NS, RGB_PERIOD_NS};

use crate::harness::flight::cache::{Fetched, RenderCache, fly_through};
use crate::harness::flight::rendered::{FlightSpec, Gusts, RenderedFlight};
use crate::harness::link::{ObserverOut, bits6, broadcast_schedule};
use crate::harness::trials::observer::{Observed, Sensing, observe_cached, observe_flying};
use crate::harness::trials::pool::run_pool_on;

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
    /// The receiver: `None`, Waggle's own for the modality; else a Python plug-in.
    pub plugin: Option<PluginOptions>,
    /// The check every frame carries after its payload.
    pub frame_check: proto::FrameCheck,
}

/// A plug-in receiver and how long one trial of it may take.
#[derive(Debug, Clone, PartialEq)]
pub struct PluginOptions {
    pub spec: PluginSpec,
    /// Wall-clock limit of one trial (`None`: none); a trial past it is `timed-out`.
    pub trial_limit: Option<Duration>,
}

impl TrialsOptions {
    /// How this condition's observers sense (`plugin`: the run's plug-in workers).
    fn sensing<'a>(&'a self, plugin: Option<&'a WorkerPool>) -> Sensing<'a> {
        Sensing {
            modality: self.modality,
            rectification: self.rectification,
            perturbation: &self.perturbation,
            plugin,
            tap: None,
            frame_check: self.frame_check,
        }
    }

    /// The run's plug-in workers, when the receiver is a plug-in.
    fn worker_pool(&self) -> Option<WorkerPool> {
        self.plugin.as_ref().map(|p| {
            WorkerPool::new(
                p.spec.clone(),
                receiver_plugin::worker::python(),
                p.trial_limit,
            )
        })
    }

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
        let (schedule, end_ns) =
            broadcast_schedule(&self.payloads, acquisition, 0, self.frame_check)?;
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

/// Pairs each ideal token with the nearest unused token of the same kind within ±1 s; the
/// tokens left on either side are kept by name and stamp, so a lost trial says which symbol it
/// lost and what was read in its place.
fn token_timing(ideal: &ObserverOut, got: &ObserverOut) -> TokenTiming {
    const WINDOW_S: f64 = 1.0;
    let mut used = vec![false; got.tokens.len()];
    let mut errors_ms = Vec::new();
    let mut missed_at = Vec::new();
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
        } else {
            missed_at.push(t.clone());
        }
    }
    let extra_at = got
        .tokens
        .iter()
        .zip(&used)
        .filter(|(_, used)| !**used)
        .map(|(g, _)| g.clone())
        .collect();
    let matched = errors_ms.len();
    let abs: Vec<f64> = errors_ms.iter().map(|e| e.abs()).collect();
    TokenTiming {
        matched,
        missed: ideal.tokens.len() - matched,
        extra: got.tokens.len() - matched,
        mean_abs_error_ms: (matched > 0).then(|| abs.iter().sum::<f64>() / matched as f64),
        max_abs_error_ms: abs.iter().copied().reduce(f64::max),
        missed_at,
        extra_at,
    }
}

/// Latency and comparison with the ideal receiver of each released frame.
fn release_times(
    schedule: &Schedule,
    ideal: &ObserverOut,
    got: &ObserverOut,
) -> (Vec<f64>, Vec<Option<f64>>) {
    let offers = schedule.offers();
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

/// A trial its plug-in receiver failed: no observer's result counts, the reason is kept.
fn failed_trial(index: u64, seed: u64, error: &PluginError) -> TrialRecord {
    TrialRecord {
        index,
        seed,
        success: false,
        observers: BTreeMap::new(),
        flight: None,
        plugin_failure: Some(PluginFailure {
            outcome: error.outcome().to_owned(),
            reason: error.to_string(),
        }),
    }
}

/// The plug-in's own fault behind `e`, if that is what ended a trial (a fault of the run — an
/// unusable interpreter, the simulator — is not the plug-in's and ends the run).
fn plugin_fault(e: &anyhow::Error) -> Option<&PluginError> {
    e.downcast_ref::<PluginError>()
        .filter(|p| p.is_plugin_fault())
}

/// Runs trial `index` on `flight` (or its own flight when the perturbation re-flies), its
/// receiver a plug-in on a worker of `plugin` when the run has one.
fn run_trial(
    opts: &TrialsOptions,
    shared: Option<&RenderedFlight>,
    plugin: Option<&WorkerPool>,
    index: u64,
    stop: &AtomicBool,
) -> Result<Option<TrialRecord>> {
    let seed = trial_seed(opts.seed, index);
    let sensing = opts.sensing(plugin);
    let own;
    let mut flight = None;
    let (spec, ideal, observed) = match shared {
        Some(f) => {
            let observed = match observe_cached(f, &sensing, seed, stop) {
                Err(ref e) if let Some(p) = plugin_fault(e) => {
                    return Ok(Some(failed_trial(index, seed, p)));
                }
                other => other?,
            };
            let Some(observed) = observed else {
                return Ok(None);
            };
            (&f.spec, &f.ideal, observed)
        }
        None => {
            let spec = opts.flight_spec(Some(seed))?;
            let observed = match observe_flying(&spec, &sensing, seed, stop) {
                Err(ref e) if let Some(p) = plugin_fault(e) => {
                    return Ok(Some(failed_trial(index, seed, p)));
                }
                other => other?,
            };
            let Some((flown, observed)) = observed else {
                return Ok(None);
            };
            flight = Some(TrialFlight {
                performer_tracking: flown.performer_tracking,
                contact_steps: flown.contact_steps,
            });
            own = (spec, flown);
            (&own.0, &own.1.ideal, observed)
        }
    };
    let want = opts.want();
    let mut observers = BTreeMap::new();
    for (
        i,
        Observed {
            out,
            messages,
            lost: messages_lost,
            counts,
        },
    ) in observed.into_iter().enumerate()
    {
        let ideal = ideal
            .get(&opts.modality)
            .and_then(|o| o.get(i))
            .context("the flight has no ideal receiver for this observer")?;
        let (latency_s, vs_ideal_s) = release_times(&spec.schedule, ideal, &out);
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
                events_received: counts.events_received,
                events_removed: counts.events_removed,
                events_removed_ego: counts.events_removed_ego,
            },
        );
    }
    Ok(Some(TrialRecord {
        index,
        seed,
        success: observers.values().all(|o| o.success)
            && flight.is_none_or(|f| f.contact_steps == 0),
        observers,
        flight,
        plugin_failure: None,
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
    cache: Option<&RenderCache>,
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
    let mut from_cache = 0;
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
            let (flight, fetched) = fly_through(cache, opts.flight_spec(None)?)?;
            from_cache += u64::from(fetched == Fetched::Hit);
            own = flight;
            Some(&own)
        }
    };
    let fly_s = started.elapsed().as_secs_f64();
    // The reference: the unperturbed flight's ideal releases (flown here when trials re-fly).
    let nominal_ideal: Vec<ObserverOut> = match shared {
        Some(f) => f.ideal.get(&opts.modality).cloned().unwrap_or_default(),
        None => {
            let (mut flight, fetched) = fly_through(cache, opts.flight_spec(None)?)?;
            from_cache += u64::from(fetched == Fetched::Hit);
            flight.ideal.remove(&opts.modality).unwrap_or_default()
        }
    };
    let trials_started = std::time::Instant::now();
    let pool = opts.worker_pool();
    if let Some(p) = &pool {
        p.check()?;
    }
    let records = run_pool_on(
        indices,
        opts.jobs,
        stop,
        |index| {
            let record = run_trial(opts, shared, pool.as_ref(), index, stop)?;
            if let Some(r) = &record {
                on_record(r)?;
            }
            Ok(record)
        },
        progress,
    );
    // Workers end here, so their CPU time counts among this process's children.
    if let Some(p) = &pool {
        p.close();
    }
    let records = records?;
    let cost = TrialsCost {
        flights: if shared.is_some() {
            u64::from(flown.is_none())
        } else {
            records.len() as u64 + 1
        },
        flights_from_cache: from_cache,
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
        real_noise: opts.perturbation.real_noise().map(|s| RealNoiseOut::of(s)),
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
         rectification {:?}; acquisition {:?}{}{}{}",
        opts.want(),
        opts.formation.placements(),
        opts.modality,
        opts.trials,
        opts.seed,
        opts.perturbation.recorded(),
        opts.rectification,
        opts.acquisition,
        // Only with a source, so a run without one keeps its fingerprint.
        opts.perturbation
            .real_noise()
            .map_or_else(String::new, |s| format!(
                "; real noise {:?}",
                RealNoiseOut::of(s)
            )),
        // Only with a plug-in, so a run of Waggle's receiver keeps its fingerprint.
        opts.plugin
            .as_ref()
            .map_or_else(String::new, |p| format!("; receiver {}", p.spec)),
        // Only with a check, likewise.
        if opts.frame_check == proto::FrameCheck::None {
            String::new()
        } else {
            format!("; frame check {}", opts.frame_check)
        }
    )
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::AtomicBool;

    use perturb::Perturbation;
    use proto::scene::Formation;
    use proto::{Modality, Rectification, RenderPath};

    use super::{Observed, TrialsOptions, observe_cached, observe_flying};
    use crate::harness::flight::rendered::fly_rendered;

    fn digest(observed: &[Observed]) -> Vec<String> {
        observed
            .iter()
            .map(|o| {
                let out = serde_json::to_string(&o.out).unwrap();
                format!("{out} {} {} {:?}", o.messages, o.lost, o.counts)
            })
            .collect()
    }

    /// A trial that flies its own flight feeds its observers straight from the renderer
    /// (nothing kept: under the cascade every render changes every pixel); they must decode
    /// exactly what they decode from the same flight's render cache.
    #[test]
    fn a_streamed_flight_observes_as_its_render_cache() {
        for modality in [Modality::Events, Modality::Rgb] {
            let opts = TrialsOptions {
                payloads: vec![0b011010],
                formation: Formation::standard(2).unwrap(),
                modality,
                trials: 1,
                seed: 3,
                perturbation: Perturbation::parse(&[
                    "flight.cascade=1",
                    "link.drop_rate=0.1",
                    "rgb.blur_renders=3",
                ])
                .unwrap(),
                jobs: 1,
                render: RenderPath::Damage,
                rectification: Rectification::Pitched,
                acquisition: Some(false),
                plugin: None,
                frame_check: proto::FrameCheck::None,
            };
            assert!(opts.perturbation.reflies());
            let mut spec = opts.flight_spec(Some(11)).unwrap();
            spec.end_ns = 3_000_000_000;
            let stop = AtomicBool::new(false);
            let (flown, streamed) = observe_flying(&spec, &opts.sensing(None), 11, &stop)
                .unwrap()
                .unwrap();
            let cache = fly_rendered(spec).unwrap();
            // Under the cascade the observers lean: every camera hands over its airframe's
            // turn, which its receiver undoes (`proto::stabilise`).
            assert!(cache.tracks.iter().all(|t| t.turned()), "{modality}");
            let cached = observe_cached(&cache, &opts.sensing(None), 11, &stop)
                .unwrap()
                .unwrap();
            assert_eq!(digest(&streamed), digest(&cached), "{modality}");
            assert!(streamed.iter().all(|o| o.messages > 0), "{modality}");
            assert_eq!(
                serde_json::to_string(&flown.ideal).unwrap(),
                serde_json::to_string(&cache.ideal).unwrap()
            );
            assert_eq!(flown.sim_ns, cache.sim_ns);
        }
    }

    /// A substitution is named on both sides: the ideal token lost and the token read in its
    /// place, each with its stamp; a token within a second of its ideal twin is matched.
    #[test]
    fn token_timing_names_what_was_lost_and_what_was_read_instead() {
        use super::{ObserverOut, token_timing};
        use crate::harness::link::TokenOut;
        let out = |tokens: &[(&str, f64)]| ObserverOut {
            payloads: Vec::new(),
            frames: Vec::new(),
            tokens: tokens
                .iter()
                .map(|&(token, t_s)| TokenOut {
                    token: token.into(),
                    t_s,
                })
                .collect(),
        };
        let ideal = out(&[("NULL", 1.0), ("BIT0", 2.0), ("NULL", 3.0)]);
        let got = out(&[("NULL", 1.04), ("BIT1", 2.08), ("NULL", 3.9)]);
        let timing = token_timing(&ideal, &got);
        assert_eq!((timing.matched, timing.missed, timing.extra), (2, 1, 1));
        let at = |token: &str, t_s| TokenOut {
            token: token.into(),
            t_s,
        };
        assert_eq!(timing.missed_at, vec![at("BIT0", 2.0)]);
        assert_eq!(timing.extra_at, vec![at("BIT1", 2.08)]);
        let same = token_timing(&ideal, &ideal);
        assert!(same.missed_at.is_empty() && same.extra_at.is_empty());
    }
}
