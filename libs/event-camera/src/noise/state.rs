//! One converter's per-pixel state and the exact rule that moves it: crossings of one pixel
//! over one interval ([`Interval::cross`]), a pixel judged with leak or low-pass
//! ([`PixelJudge`]) and one settled by its key bounds ([`State::settle`]).

use super::LOWPASS_SETTLED;
use super::leak::{JitterCache, LeakModel};
use super::schedule::LeakSchedule;
use super::shot::ShotMap;
use crate::converter::no_event_bounds;
use crate::event::Polarity;
use crate::prefetch::prefetch;

/// Sort order of a hot pixel's event: after every threshold crossing of its pixel and time.
pub(super) const ORDER_HOT: u32 = 1 << 31;

/// (t, pixel index, order, polarity) of one event of the interval being converted.
pub(super) type Crossing = (u64, u32, u32, Polarity);

/// Per-pixel state once the first frame has been seen.
#[derive(Clone)]
pub(super) struct State {
    pub(super) first_stamp_ns: u64,
    pub(super) last_stamp_ns: u64,
    /// Keys of the previous frame (start of the interpolation interval).
    pub(super) prev_keys: Vec<u32>,
    /// With shot noise thinned by brightness: [`ShotMap::coarse`] of each pixel's key in
    /// `prev_keys`, kept with it by [`State::set_key`].
    pub(super) coarse: Vec<u8>,
    /// Without leak: scratch for the keys of the frame being converted (swapped afterwards).
    pub(super) keys: Vec<u32>,
    /// Without leak: each pixel's closed no-event key interval `[lo, lo + span]`.
    pub(super) lo: Vec<u32>,
    pub(super) span: Vec<u32>,
    pub(super) l_init: Vec<f64>,
    pub(super) level: Vec<i32>,
    /// With a refractory period: earliest time the pixel may emit again (0: any time).
    pub(super) ready_at: Vec<u64>,
    /// With leak: the pixels whose next upward leak crossing is due, see [`LeakSchedule`].
    pub(super) leak: LeakSchedule,
    /// With leak jitter: where each pixel's leak sum stands.
    pub(super) jitter: JitterCache,
    /// With the low-pass: each pixel's low-passed log intensity `P`.
    pub(super) lp: Vec<f64>,
    /// With the low-pass: the pixels whose `P` has not reached `L`, and a flag per pixel.
    pub(super) unsettled: Vec<u32>,
    pub(super) is_unsettled: Vec<bool>,
    /// With the low-pass: the stamp of the frame that last judged each pixel.
    pub(super) judged_ns: Vec<u64>,
    pub(super) flagged: Vec<u32>,
    pub(super) crossings: Vec<Crossing>,
    /// With leak or low-pass: the pixels one frame judges from its settling list or its leak
    /// schedule (scratch).
    pub(super) to_judge: Vec<u32>,
}

/// The interval `(t0, t0 + dt]` between two frames and the refractory period.
pub(super) struct Interval {
    pub(super) t0: u64,
    pub(super) dt: u64,
    pub(super) refractory_ns: u64,
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
    pub(super) fn cross(
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

/// How many listed pixels ahead [`PixelJudge::judge_listed`] asks for: enough for the
/// memory reads to overlap, few enough that the lines are still in cache when used.
const JUDGE_AHEAD: usize = 8;

/// One judged frame's constants: judges a pixel exactly as the rule states.
pub(super) struct PixelJudge<'a> {
    pub(super) table: &'a [f64],
    pub(super) thresholds: &'a [f64],
    /// The leak terms (None without leak).
    pub(super) leak: Option<&'a LeakModel>,
    /// 0: no low-pass.
    pub(super) cutoff_hz: f64,
    pub(super) g0: f64,
    pub(super) g1: f64,
    pub(super) stamp_ns: u64,
    pub(super) at: &'a Interval,
    pub(super) shot: &'a ShotMap,
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

    /// Asks for every per-pixel value [`PixelJudge::judge`] reads of pixel `i` (the luminance
    /// table aside: its entries repeat across a scene and mostly stay cached).
    #[inline(always)]
    pub(super) fn prefetch(&self, state: &State, i: usize) {
        prefetch(self.thresholds, i);
        prefetch(&state.l_init, i);
        prefetch(&state.level, i);
        prefetch(&state.prev_keys, i);
        prefetch(&state.ready_at, i);
        if self.cutoff_hz > 0.0 {
            prefetch(&state.lp, i);
            prefetch(&state.judged_ns, i);
            prefetch(&state.is_unsettled, i);
        }
        if let Some(leak) = self.leak {
            leak.prefetch(&state.jitter, i);
            state.leak.prefetch(i);
        }
    }

    /// Judges each pixel of `state.to_judge` at its key in `prev_keys` (skipping one this frame
    /// already judged), asking for the per-pixel values of the pixel [`JUDGE_AHEAD`] places on.
    /// The pixels are scattered over the sensor and each judgement reads about a dozen arrays
    /// (≈ 25 MB in all for 640×480 with every term on), so without the hint most reads missed
    /// the cache (≈ 470 ns per judged pixel in a noisy trial). The order is the list's, as when
    /// each was judged on its own: the hint changes no result.
    pub(super) fn judge_listed(&self, state: &mut State) {
        let list = std::mem::take(&mut state.to_judge);
        for (k, &i) in list.iter().enumerate() {
            if let Some(&ahead) = list.get(k + JUDGE_AHEAD) {
                self.prefetch(state, ahead as usize);
            }
            let i = i as usize;
            if self.cutoff_hz > 0.0 && state.judged_ns[i] == self.stamp_ns {
                continue;
            }
            let key = state.prev_keys[i];
            self.judge(state, i, key);
        }
        state.to_judge = list;
    }

    /// Pixel `i` has key `key` at the frame (its previous key still in `prev_keys`): records its
    /// crossings, its new level, key and `P`, and reschedules it.
    pub(super) fn judge(&self, state: &mut State, i: usize, key: u32) {
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
        if key != state.prev_keys[i] {
            state.set_key(i, key, self.shot);
        }
        // A pixel still settling is judged again at the next frame from the settling list, so
        // its leak crossing need not be scheduled until it has settled (an entry it already has
        // may still hand it out: judging a pixel at any frame follows the exact rule).
        let settling = self.cutoff_hz > 0.0 && state.is_unsettled[i];
        if let Some(leak) = self.leak.filter(|_| !settling) {
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
    /// Pixel `i`'s key at the frame is now `key`.
    #[inline(always)]
    pub(super) fn set_key(&mut self, i: usize, key: u32, shot: &ShotMap) {
        self.prev_keys[i] = key;
        if let Some(coarse) = self.coarse.get_mut(i) {
            *coarse = shot.coarse(key);
        }
    }

    /// Every pixel's coarse thinning bound from its key (after the keys were replaced whole).
    pub(super) fn set_coarse(&mut self, shot: &ShotMap) {
        if shot.thins() {
            self.coarse.clear();
            self.coarse
                .extend(self.prev_keys.iter().map(|&key| shot.coarse(key)));
        }
    }

    /// Without leak: pixel `i` (threshold `c`) now has key `key` (its previous key still in
    /// `prev_keys`): records its crossings and its new level and bounds. No-op in bounds.
    #[inline]
    pub(super) fn settle(&mut self, i: usize, key: u32, c: f64, table: &[f64], at: &Interval) {
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
