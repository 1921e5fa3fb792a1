//! The noisy converter: the ideal converter's rules with [`EventNoise`]'s terms (see the
//! module docs of [`super`]).

use proto::PixelRect;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Poisson, StandardNormal};

use super::leak::{JitterCache, LeakModel, LeakSchedule};
use super::shot::{ShotDraws, ShotMap};
use super::{
    EventNoise, LOWPASS_SETTLED, MIN_PIXEL_THRESHOLD, STREAM_HOT, STREAM_SHOT, STREAM_THRESHOLD,
    rng_stream,
};
use crate::converter::no_event_bounds;
use crate::error::{ConvertError, NoiseError};
use crate::event::{Event, Polarity};
use crate::kernel::{CHUNK, Isa, scan};
use crate::luminance::{luminance_key, table_for};

/// Sort order of a hot pixel's event: after every threshold crossing of its pixel and time.
const ORDER_HOT: u32 = 1 << 31;

/// (t, pixel index, order, polarity) of one event of the interval being converted.
type Crossing = (u64, u32, u32, Polarity);

#[derive(Clone, Debug)]
struct HotPixel {
    index: u32,
    /// ψ_j in [0, 1).
    phase: f64,
    /// k of its next event.
    next: u64,
}

/// Per-pixel state once the first frame has been seen.
#[derive(Clone)]
struct State {
    first_stamp_ns: u64,
    last_stamp_ns: u64,
    /// Keys of the previous frame (start of the interpolation interval).
    prev_keys: Vec<u32>,
    /// Without leak: scratch for the keys of the frame being converted (swapped afterwards).
    keys: Vec<u32>,
    /// Without leak: each pixel's closed no-event key interval `[lo, lo + span]`.
    lo: Vec<u32>,
    span: Vec<u32>,
    l_init: Vec<f64>,
    level: Vec<i32>,
    /// With a refractory period: earliest time the pixel may emit again (0: any time).
    ready_at: Vec<u64>,
    /// With leak: the pixels whose next upward leak crossing is due, see [`LeakSchedule`].
    leak: LeakSchedule,
    /// With leak jitter: where each pixel's leak sum stands.
    jitter: JitterCache,
    /// With the low-pass: each pixel's low-passed log intensity `P`.
    lp: Vec<f64>,
    /// With the low-pass: the pixels whose `P` has not reached `L`, and a flag per pixel.
    unsettled: Vec<u32>,
    is_unsettled: Vec<bool>,
    /// With the low-pass: the stamp of the frame that last judged each pixel.
    judged_ns: Vec<u64>,
    flagged: Vec<u32>,
    crossings: Vec<Crossing>,
}

/// The interval `(t0, t0 + dt]` between two frames and the refractory period.
struct Interval {
    t0: u64,
    dt: u64,
    refractory_ns: u64,
}

impl Interval {
    /// Crossings of pixel `i` from `d0` to `d1` with threshold `c`, starting at `level`;
    /// appends the emitted ones to `out` and returns the new level. `ready_at` is empty when
    /// there is no refractory period.
    #[inline]
    #[expect(
        clippy::too_many_arguments,
        reason = "one pixel's scalars and the two outputs"
    )]
    fn cross(
        &self,
        i: usize,
        d0: f64,
        d1: f64,
        c: f64,
        mut level: i32,
        ready_at: &mut [u64],
        out: &mut Vec<Crossing>,
    ) -> i32 {
        let time_of = |level: i32| {
            let frac = (f64::from(level) * c - d0) / (d1 - d0);
            self.t0 + ((frac * self.dt as f64).ceil() as u64).clamp(1, self.dt)
        };
        let refractory_ns = self.refractory_ns;
        let mut order = 0u32;
        let mut emit = |t: u64, polarity: Polarity, order: u32| {
            if refractory_ns != 0 {
                if t < ready_at[i] {
                    return;
                }
                ready_at[i] = t.saturating_add(refractory_ns);
            }
            out.push((t, i as u32, order.min(ORDER_HOT - 1), polarity));
        };
        while d1 >= f64::from(level + 1) * c {
            level += 1;
            emit(time_of(level), Polarity::On, order);
            order = order.saturating_add(1);
        }
        while d1 <= f64::from(level - 1) * c {
            level -= 1;
            emit(time_of(level), Polarity::Off, order);
            order = order.saturating_add(1);
        }
        level
    }
}

/// Event converter with the [`EventNoise`] non-idealities; with ideal noise its events are
/// bit-identical to [`crate::Converter`]'s.
#[derive(Clone)]
pub struct NoisyConverter {
    width: u16,
    height: u16,
    threshold: f64,
    noise: EventNoise,
    isa: Isa,
    table: &'static [f64],
    /// C_i of every pixel.
    thresholds: Vec<f64>,
    /// φ_i, s_i and the jitter of every pixel's leak (empty without leak).
    leak: LeakModel,
    hot: Vec<HotPixel>,
    shot_map: ShotMap,
    shot_rng: ChaCha8Rng,
    /// Scratch of the interval's shot events.
    shot: ShotDraws,
    state: Option<State>,
}

impl std::fmt::Debug for NoisyConverter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NoisyConverter")
            .field("width", &self.width)
            .field("height", &self.height)
            .field("threshold", &self.threshold)
            .field("noise", &self.noise)
            .field(
                "last_stamp_ns",
                &self.state.as_ref().map(|s| s.last_stamp_ns),
            )
            .finish_non_exhaustive()
    }
}

impl NoisyConverter {
    /// A converter for `width`×`height` RGB frames with nominal contrast threshold `threshold`
    /// (C) and the non-idealities `noise`. Draws the threshold map, leak phases and hot pixels.
    pub fn new(
        width: u16,
        height: u16,
        threshold: f64,
        noise: &EventNoise,
    ) -> Result<Self, ConvertError> {
        ConvertError::check_sensor(width, height, threshold)?;
        noise.validate()?;
        let n = usize::from(width) * usize::from(height);
        if noise.hot_pixels as usize > n {
            return Err(NoiseError::TooManyHotPixels {
                hot_pixels: noise.hot_pixels,
                pixels: n,
            }
            .into());
        }
        let thresholds = if noise.threshold_sigma > 0.0 {
            let mut rng = rng_stream(noise.seed, STREAM_THRESHOLD);
            (0..n)
                .map(|_| {
                    let z: f64 = rng.sample(StandardNormal);
                    (threshold + noise.threshold_sigma * z).max(MIN_PIXEL_THRESHOLD.min(threshold))
                })
                .collect()
        } else {
            vec![threshold; n]
        };
        let hot = if noise.hot_pixels > 0 {
            let mut rng = rng_stream(noise.seed, STREAM_HOT);
            let chosen = rand::seq::index::sample(&mut rng, n, noise.hot_pixels as usize);
            chosen
                .into_iter()
                .map(|index| HotPixel {
                    index: index as u32,
                    phase: rng.r#gen::<f64>(),
                    next: 0,
                })
                .collect()
        } else {
            Vec::new()
        };
        Ok(Self {
            width,
            height,
            threshold,
            noise: *noise,
            isa: Isa::detect(),
            table: table_for(noise.linlog_dn),
            leak: LeakModel::new(noise, n),
            shot_map: ShotMap::new(threshold, &thresholds, noise.shot_noise_bright_drop),
            thresholds,
            hot,
            shot_rng: rng_stream(noise.seed, STREAM_SHOT),
            shot: ShotDraws::default(),
            state: None,
        })
    }

    pub fn width(&self) -> u16 {
        self.width
    }

    pub fn height(&self) -> u16 {
        self.height
    }

    /// Nominal contrast threshold C.
    pub fn threshold(&self) -> f64 {
        self.threshold
    }

    pub fn noise(&self) -> &EventNoise {
        &self.noise
    }

    /// True once the first frame has initialised the references.
    pub fn is_initialised(&self) -> bool {
        self.state.is_some()
    }

    fn index(&self, x: u16, y: u16) -> usize {
        usize::from(y) * usize::from(self.width) + usize::from(x)
    }

    /// Current integer level n of pixel (x, y) (0 before the first frame or outside).
    pub fn level(&self, x: u16, y: u16) -> i32 {
        let i = self.index(x, y);
        self.state
            .as_ref()
            .and_then(|s| s.level.get(i).copied())
            .unwrap_or(0)
    }

    /// Contrast threshold `C_i` of pixel (x, y) (NaN outside the sensor).
    pub fn threshold_of(&self, x: u16, y: u16) -> f64 {
        self.thresholds
            .get(self.index(x, y))
            .copied()
            .unwrap_or(f64::NAN)
    }

    /// Leak phase `φ_i` of pixel (x, y) in [0, 1) (0 without leak, NaN outside the sensor).
    pub fn leak_phase_of(&self, x: u16, y: u16) -> f64 {
        let i = self.index(x, y);
        if i >= self.thresholds.len() {
            return f64::NAN;
        }
        self.leak.phases.get(i).copied().unwrap_or(0.0)
    }

    /// Leak rate of pixel (x, y) relative to `leak_hz` (`s_i`; 1 without spread, NaN outside).
    pub fn leak_scale_of(&self, x: u16, y: u16) -> f64 {
        let i = self.index(x, y);
        if i >= self.thresholds.len() {
            return f64::NAN;
        }
        self.leak.scale(i)
    }

    /// Slope of pixel (x, y)'s leak sum in leak period `m` (`w_{i,m}`; 1 without jitter).
    pub fn leak_weight_of(&self, x: u16, y: u16, m: u32) -> f64 {
        self.leak.weight(self.index(x, y), m)
    }

    /// The log intensity the pixels see: `L` of a luminance key (lin-log or log curve).
    pub fn log_intensity_of_key(&self, key: u32) -> f64 {
        self.table.get(key as usize).copied().unwrap_or(f64::NAN)
    }

    /// True when pixels must be judged one by one (leak or low-pass), not by key bounds.
    fn judged(&self) -> bool {
        self.noise.leak_hz > 0.0 || self.noise.cutoff_hz > 0.0
    }

    /// The hot pixels (x, y), in the order they were drawn.
    pub fn hot_pixel_positions(&self) -> Vec<(u16, u16)> {
        let w = u32::from(self.width);
        self.hot
            .iter()
            .map(|h| ((h.index % w) as u16, (h.index / w) as u16))
            .collect()
    }

    /// Converts the frame rendered at `stamp_ns` (row-major RGB, 3 bytes per pixel) and
    /// **appends** the events of the interval since the previous frame to `out`, sorted by
    /// (time, pixel index, order). The first frame only initialises. On error nothing changes.
    pub fn push(
        &mut self,
        stamp_ns: u64,
        rgb: &[u8],
        out: &mut Vec<Event>,
    ) -> Result<(), ConvertError> {
        ConvertError::check_frame(rgb, self.width, self.height)?;
        if self.state.is_none() {
            self.state = Some(self.initial_state(stamp_ns, rgb));
            return Ok(());
        }
        let at = self.interval(stamp_ns)?;
        if self.judged() {
            let full = PixelRect {
                x: 0,
                y: 0,
                width: self.width,
                height: self.height,
            };
            self.convert_judged(stamp_ns, rgb, Some(full), &at);
        } else {
            self.convert_scan(rgb, &at);
        }
        self.finish(stamp_ns, &at, out);
        Ok(())
    }

    /// Like [`NoisyConverter::push`] for a frame known to equal the previous one outside
    /// `region` (`None`: equal everywhere), with exactly the events of a full push. Without leak
    /// only the region's pixels are read (an unchanged key cannot cross a level); with leak
    /// every pixel moves, so the whole frame is converted. The first frame must be a full push.
    pub fn push_region(
        &mut self,
        stamp_ns: u64,
        rgb: &[u8],
        region: Option<PixelRect>,
        out: &mut Vec<Event>,
    ) -> Result<(), ConvertError> {
        ConvertError::check_frame(rgb, self.width, self.height)?;
        ConvertError::check_region(region, self.width, self.height)?;
        if self.state.is_none() {
            return Err(ConvertError::RegionBeforeFirstFrame);
        }
        let at = self.interval(stamp_ns)?;
        if self.judged() {
            self.convert_judged(stamp_ns, rgb, region, &at);
        } else if let Some(r) = region {
            self.convert_region(rgb, r, &at);
        } else if let Some(state) = self.state.as_mut() {
            state.crossings.clear();
        }
        self.finish(stamp_ns, &at, out);
        Ok(())
    }

    /// The interval ending at `stamp_ns`; the state must exist.
    fn interval(&self, stamp_ns: u64) -> Result<Interval, ConvertError> {
        let last = self.state.as_ref().map_or(0, |s| s.last_stamp_ns);
        ConvertError::check_stamp(stamp_ns, last)?;
        Ok(Interval {
            t0: last,
            dt: stamp_ns - last,
            refractory_ns: self.noise.refractory_ns,
        })
    }

    fn initial_state(&self, stamp_ns: u64, rgb: &[u8]) -> State {
        let n = rgb.len() / 3;
        let keys: Vec<u32> = rgb
            .chunks_exact(3)
            .map(|p| luminance_key(p[0], p[1], p[2]))
            .collect();
        let l_init: Vec<f64> = keys.iter().map(|&k| self.table[k as usize]).collect();
        let (mut lo, mut span) = (Vec::new(), Vec::new());
        let judged = self.judged();
        if !judged {
            (lo, span) = (vec![0; n], vec![0; n]);
            // Rendered backgrounds repeat keys along rows; with one threshold for all pixels
            // the last search is reused when they do.
            let mut memo: Option<(u32, u64, (u32, u32))> = None;
            for (i, &key) in keys.iter().enumerate() {
                let c = self.thresholds[i];
                let bounds = match memo {
                    Some((k, cb, b)) if k == key && cb == c.to_bits() => b,
                    _ => {
                        let b = no_event_bounds(self.table, l_init[i], 0, c);
                        memo = Some((key, c.to_bits(), b));
                        b
                    }
                };
                (lo[i], span[i]) = bounds;
            }
        }
        State {
            first_stamp_ns: stamp_ns,
            last_stamp_ns: stamp_ns,
            prev_keys: keys,
            keys: if lo.is_empty() {
                Vec::new()
            } else {
                vec![0; n]
            },
            lo,
            span,
            level: vec![0; n],
            ready_at: if self.noise.refractory_ns > 0 {
                vec![0; n]
            } else {
                Vec::new()
            },
            leak: if self.noise.leak_hz > 0.0 {
                let jitter = self.leak.cache();
                // Level 0, d = C·Λ_i(g): the first crossing where Λ_i(g) = 1.
                LeakSchedule::new((0..n).map(|i| self.leak.due(&jitter, i, 0, 0.0, 1.0)))
            } else {
                LeakSchedule::default()
            },
            jitter: self.leak.cache(),
            lp: if self.noise.cutoff_hz > 0.0 {
                l_init.clone()
            } else {
                Vec::new()
            },
            l_init,
            unsettled: Vec::new(),
            is_unsettled: if self.noise.cutoff_hz > 0.0 {
                vec![false; n]
            } else {
                Vec::new()
            },
            judged_ns: if self.noise.cutoff_hz > 0.0 {
                vec![0; n]
            } else {
                Vec::new()
            },
            flagged: Vec::new(),
            crossings: Vec::new(),
        }
    }

    /// Without leak, whole frame: the vectorised key scan, then the flagged chunks.
    fn convert_scan(&mut self, rgb: &[u8], at: &Interval) {
        let Some(state) = self.state.as_mut() else {
            return;
        };
        let n = state.level.len();
        scan(
            self.isa,
            rgb,
            &state.lo,
            &state.span,
            &mut state.keys,
            &mut state.flagged,
        );
        state.crossings.clear();
        for k in 0..state.flagged.len() {
            let start = state.flagged[k] as usize * CHUNK;
            for i in start..(start + CHUNK).min(n) {
                let key = state.keys[i];
                state.settle(i, key, self.thresholds[i], self.table, at);
            }
        }
        std::mem::swap(&mut state.keys, &mut state.prev_keys);
    }

    /// Without leak, only `region`'s pixels.
    fn convert_region(&mut self, rgb: &[u8], r: PixelRect, at: &Interval) {
        let Some(state) = self.state.as_mut() else {
            return;
        };
        let width = usize::from(self.width);
        state.crossings.clear();
        for y in usize::from(r.y)..usize::from(r.y) + usize::from(r.height) {
            let row = y * width;
            for i in row + usize::from(r.x)..row + usize::from(r.x) + usize::from(r.width) {
                let key = luminance_key(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]);
                state.settle(i, key, self.thresholds[i], self.table, at);
                state.prev_keys[i] = key;
            }
        }
    }

    /// With leak or low-pass: the pixels of `region` whose key changed, the pixels whose
    /// low-passed intensity is still settling, then every pixel whose leak crossing is due by
    /// the frame's time, each judged once, exactly as the rule states (`d` at the frame's time
    /// against its two firing levels). Any other pixel has an unchanged, settled input and a `d`
    /// that only grows with the leak, so it cannot cross before its due time (see
    /// [`LeakSchedule`]): skipping it gives the same events as judging every pixel.
    fn convert_judged(
        &mut self,
        stamp_ns: u64,
        rgb: &[u8],
        region: Option<PixelRect>,
        at: &Interval,
    ) {
        let Some(state) = self.state.as_mut() else {
            return;
        };
        let leak = |t: u64| self.noise.leak_hz * ((t - state.first_stamp_ns) as f64 * 1e-9);
        let (g0, g1) = (leak(at.t0), leak(stamp_ns));
        let pixel = PixelJudge {
            table: self.table,
            thresholds: &self.thresholds,
            leak: (self.noise.leak_hz > 0.0).then_some(&self.leak),
            cutoff_hz: self.noise.cutoff_hz,
            g0,
            g1,
            stamp_ns,
            at,
        };
        state.crossings.clear();
        let settling = std::mem::take(&mut state.unsettled);
        for &i in &settling {
            state.is_unsettled[i as usize] = false;
        }
        if let Some(r) = region {
            let width = usize::from(self.width);
            for y in usize::from(r.y)..usize::from(r.y) + usize::from(r.height) {
                let row = y * width;
                for i in row + usize::from(r.x)..row + usize::from(r.x) + usize::from(r.width) {
                    let key = luminance_key(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]);
                    if key != state.prev_keys[i] {
                        pixel.judge(state, i, key);
                    }
                }
            }
        }
        for &i in &settling {
            let i = i as usize;
            if state.judged_ns[i] != stamp_ns {
                let key = state.prev_keys[i];
                pixel.judge(state, i, key);
            }
        }
        if pixel.leak.is_some() {
            while let Some(i) = state.leak.pop_due(g1) {
                let key = state.prev_keys[i];
                pixel.judge(state, i, key);
            }
        }
    }

    /// Adds the interval's hot-pixel and shot events, sorts, appends to `out`, closes the
    /// interval.
    fn finish(&mut self, stamp_ns: u64, at: &Interval, out: &mut Vec<Event>) {
        let Some(state) = self.state.as_mut() else {
            return;
        };
        if !self.hot.is_empty() {
            let period_ns = 1e9 / self.noise.hot_pixel_hz;
            for hot in &mut self.hot {
                loop {
                    let offset = ((hot.next as f64 + hot.phase) * period_ns).ceil() as u64;
                    let t = state.first_stamp_ns.saturating_add(offset.max(1));
                    if t > stamp_ns {
                        break;
                    }
                    state
                        .crossings
                        .push((t, hot.index, ORDER_HOT, Polarity::On));
                    hot.next += 1;
                }
            }
        }
        state
            .crossings
            .sort_unstable_by_key(|&(t_ns, i, order, _)| (t_ns, i, order));
        let n = state.level.len();
        let lambda =
            self.noise.shot_noise_hz * self.shot_map.mean_weight * n as f64 * (at.dt as f64 * 1e-9);
        let shot = &mut self.shot;
        shot.keys.clear();
        if let Ok(poisson) = Poisson::new(lambda) {
            let count = poisson.sample(&mut self.shot_rng) as u64;
            shot.draw(
                &mut self.shot_rng,
                count,
                n as u32,
                at.dt,
                &self.shot_map,
                &state.prev_keys,
            );
        }
        let w = u32::from(self.width);
        let event = |t_ns: u64, i: u32, polarity: Polarity| Event {
            t_ns,
            x: (i % w) as u16,
            y: (i / w) as u16,
            polarity,
        };
        // Merge: crossings and hot events before shot events of the same time and pixel.
        out.reserve(state.crossings.len() + shot.keys.len());
        let mut crossings = state.crossings.iter().peekable();
        for &key in &shot.keys {
            let (t_ns, i, polarity) = shot.unpack(key, at.t0);
            while let Some(&&(tc, ic, _, pc)) = crossings.peek() {
                if (tc, ic) > (t_ns, i) {
                    break;
                }
                out.push(event(tc, ic, pc));
                crossings.next();
            }
            out.push(event(t_ns, i, polarity));
        }
        out.extend(crossings.map(|&(t_ns, i, _, polarity)| event(t_ns, i, polarity)));
        state.last_stamp_ns = stamp_ns;
    }
}

/// One judged frame's constants: judges a pixel exactly as the rule states.
struct PixelJudge<'a> {
    table: &'a [f64],
    thresholds: &'a [f64],
    /// The leak terms (None without leak).
    leak: Option<&'a LeakModel>,
    /// 0: no low-pass.
    cutoff_hz: f64,
    g0: f64,
    g1: f64,
    stamp_ns: u64,
    at: &'a Interval,
}

impl PixelJudge<'_> {
    /// `P` after a frame: `p` moved towards `l` (the new frame's log intensity, luminance
    /// key `key`) by `ε = min(I·dt·2π·f_c, 1)`, snapped to `l` once within
    /// [`LOWPASS_SETTLED`].
    fn low_pass(&self, p: f64, l: f64, key: u32) -> f64 {
        let intensity = (f64::from(key) / 1000.0 + 20.0) / 275.0;
        let dt_s = self.at.dt as f64 * 1e-9;
        let eps = (intensity * dt_s * std::f64::consts::TAU * self.cutoff_hz).min(1.0);
        if eps >= 1.0 {
            return l;
        }
        let next = (1.0 - eps) * p + eps * l;
        if (l - next).abs() <= LOWPASS_SETTLED {
            l
        } else {
            next
        }
    }

    /// Pixel `i` has key `key` at the frame (its previous key still in `prev_keys`): records its
    /// crossings, its new level, key and `P`, and reschedules it.
    fn judge(&self, state: &mut State, i: usize, key: u32) {
        let (c, l_init) = (self.thresholds[i], state.l_init[i]);
        let (p0, p1) = if self.cutoff_hz > 0.0 {
            state.judged_ns[i] = self.stamp_ns;
            let p0 = state.lp[i];
            let p1 = self.low_pass(p0, self.table[key as usize], key);
            state.lp[i] = p1;
            if p1 != self.table[key as usize] && !state.is_unsettled[i] {
                state.is_unsettled[i] = true;
                state.unsettled.push(i as u32);
            }
            (p0, p1)
        } else {
            (
                self.table[state.prev_keys[i] as usize],
                self.table[key as usize],
            )
        };
        let delta = p1 - l_init;
        // Λ_i at both frames, the earlier first: the jitter cache only moves forwards.
        let leak_at = self.leak.map(|leak| {
            let before = leak.at(&mut state.jitter, i, self.g0, true);
            (before, leak.at(&mut state.jitter, i, self.g1, true))
        });
        let d1 = match leak_at {
            Some((_, after)) => delta + c * after,
            None => delta,
        };
        let mut level = state.level[i];
        if d1 >= f64::from(level + 1) * c || d1 <= f64::from(level - 1) * c {
            let d0 = match leak_at {
                Some((before, _)) => (p0 - l_init) + c * before,
                None => p0 - l_init,
            };
            level = self.at.cross(
                i,
                d0,
                d1,
                c,
                level,
                &mut state.ready_at,
                &mut state.crossings,
            );
            state.level[i] = level;
        }
        state.prev_keys[i] = key;
        if let Some(leak) = self.leak {
            let due = leak.due(&state.jitter, i, level, delta, c);
            // Judged early (inside the margin) without crossing: due again at the next frame.
            let due = if due <= self.g1 {
                self.g1.next_up()
            } else {
                due
            };
            state.leak.set(i, due);
        }
    }
}

impl State {
    /// Without leak: pixel `i` (threshold `c`) now has key `key` (its previous key still in
    /// `prev_keys`): records its crossings and its new level and bounds. No-op in bounds.
    #[inline]
    fn settle(&mut self, i: usize, key: u32, c: f64, table: &[f64], at: &Interval) {
        if key.wrapping_sub(self.lo[i]) <= self.span[i] {
            return;
        }
        let l_init = self.l_init[i];
        let d0 = table[self.prev_keys[i] as usize] - l_init;
        let d1 = table[key as usize] - l_init;
        let level = at.cross(
            i,
            d0,
            d1,
            c,
            self.level[i],
            &mut self.ready_at,
            &mut self.crossings,
        );
        self.level[i] = level;
        (self.lo[i], self.span[i]) = no_event_bounds(table, l_init, level, c);
    }
}
