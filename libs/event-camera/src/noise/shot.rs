//! Shot noise: where the spurious events of one interval fall, and their sort.
//!
//! The rate of pixel i is `shot_noise_hz · (C / C_i) · (1 − b·I_i)`, as v2e's
//! (`emulator_utils.generate_shot_noise`): a pixel with a lower threshold is noisier in
//! proportion, and a brighter one quieter, `I_i = (Y_i + 20) / 275` the pixel's intensity on
//! v2e's scale (`Y_i` its luminance 0–255 at the end of the interval) and `b` the
//! `shot_noise_bright_drop` (v2e: 1 − `SHOT_NOISE_INTEN_FACTOR` = 0.75). Candidates are drawn
//! at the rate `shot_noise_hz · mean(C / C_i)` over the sensor, at a pixel drawn in proportion
//! to `C / C_i` (Walker's alias method), then kept with probability `1 − b·I_i` (thinning).
//! Each candidate uses two 64-bit draws whatever the terms: the pixel column and the alias coin
//! from the first, the time, the polarity and the thinning coin from the second, so the
//! uniform sensor (`C_i = C`, `b = 0`) draws exactly what it always did.

use rand::{Rng, RngCore};
use rand_chacha::ChaCha8Rng;

use crate::event::Polarity;
use crate::luminance::MAX_KEY;
use crate::prefetch::prefetch;

/// Most bucket-index bits of the shot-event sort (2²⁰ counters at most: 4 MB).
const MAX_BUCKET_BITS: u32 = 20;

/// Walker alias table of the pixels' relative shot rates `C / C_i`.
#[derive(Clone, Debug)]
struct Alias {
    /// Per column: the probability (scaled to 2³², saturated at `u32::MAX`) that it keeps its
    /// own pixel, and the pixel it aliases to. One 8-byte entry, so a draw costs one cache
    /// miss, not two. A column that always keeps its pixel (2³²) aliases to itself, so
    /// saturating its probability changes no draw.
    entries: Vec<[u32; 2]>,
}

impl Alias {
    /// Vose's construction; deterministic for given weights.
    fn new(weights: &[f64]) -> Self {
        let n = weights.len();
        let total: f64 = weights.iter().sum();
        let mut scaled: Vec<f64> = weights.iter().map(|w| w * n as f64 / total).collect();
        let (mut small, mut large): (Vec<usize>, Vec<usize>) =
            (0..n).partition(|&i| scaled[i] < 1.0);
        let mut keep = vec![1u64 << 32; n];
        let mut alias: Vec<u32> = (0..n as u32).collect();
        while let (Some(s), Some(&l)) = (small.pop(), large.last()) {
            keep[s] = (scaled[s] * (1u64 << 32) as f64) as u64;
            alias[s] = l as u32;
            scaled[l] -= 1.0 - scaled[s];
            if scaled[l] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        let entries = keep
            .iter()
            .zip(&alias)
            .map(|(&k, &a)| [u32::try_from(k).unwrap_or(u32::MAX), a])
            .collect();
        Self { entries }
    }

    /// The pixel of column `column` given 32 random bits `coin`.
    #[inline(always)]
    fn pixel(&self, column: u64, coin: u64) -> u64 {
        let [keep, alias] = self.entries[column as usize];
        // A select, not a branch: the coin is unpredictable by construction.
        let to_alias = u64::from(coin >= u64::from(keep)).wrapping_neg();
        column ^ ((column ^ u64::from(alias)) & to_alias)
    }
}

/// The per-pixel shot-noise rate map (uniform when both factors are off).
#[derive(Clone, Debug, Default)]
pub(super) struct ShotMap {
    alias: Option<Alias>,
    /// mean(C / C_i): the candidates' rate relative to `shot_noise_hz`.
    pub mean_weight: f64,
    /// Per luminance key (0..=[`MAX_KEY`]): a candidate is kept when its 31-bit coin is below
    /// this (empty without the brightness term). See [`keep_below`].
    keep_below: Vec<u32>,
    /// Per luminance key: the top 8 of the 31 bits of `keep_below` (see [`ShotMap::coarse`]).
    coarse: Vec<u8>,
}

/// The integer form of the thinning test `coin / 2³¹ < keep`, `keep = 1 − b·(Y + 20)/275` for
/// luminance key `key` (`Y = key / 1000`): `coin / 2³¹` is exact in f64 and scaling by 2³¹ is
/// exact, so the test is `coin < keep·2³¹`, which for an integer coin is `coin < ⌈keep·2³¹⌉`.
/// One table read per candidate replaces two divisions and a conversion, with the same
/// decisions (`keep_below_decides_as_the_float_test`).
fn keep_below(bright_drop: f64, key: u32) -> u32 {
    let y = f64::from(key) / 1000.0;
    let keep = 1.0 - bright_drop * (y + 20.0) / 275.0;
    let scaled = (keep * f64::from(1u32 << 31)).ceil();
    scaled.clamp(0.0, f64::from(1u32 << 31)) as u32
}

impl ShotMap {
    /// The map for thresholds `c_i` around the nominal `c`.
    pub fn new(c: f64, thresholds: &[f64], bright_drop: f64) -> Self {
        let uniform = thresholds.iter().all(|&ci| ci == c);
        let (alias, mean_weight) = if uniform || thresholds.is_empty() {
            (None, 1.0)
        } else {
            let weights: Vec<f64> = thresholds.iter().map(|&ci| c / ci).collect();
            let mean = weights.iter().sum::<f64>() / weights.len() as f64;
            (Some(Alias::new(&weights)), mean)
        };
        let keep_below = if bright_drop > 0.0 {
            (0..=MAX_KEY)
                .map(|key| keep_below(bright_drop, key))
                .collect()
        } else {
            Vec::new()
        };
        let coarse = keep_below.iter().map(|&k| coarse_of(k)).collect();
        Self {
            alias,
            mean_weight,
            keep_below,
            coarse,
        }
    }

    /// Whether the thinning applies at all (the brightness term is on).
    pub fn thins(&self) -> bool {
        !self.keep_below.is_empty()
    }

    /// The coarse thinning bound of luminance key `key`: a per-pixel copy of it, 1 byte where
    /// the key is 4, lets a candidate be decided from a table that stays in cache (a 640×480
    /// sensor's keys are 1.2 MB, beyond one core's L2; the byte per pixel 0.3 MB). Waiting for
    /// the key was a quarter of the shot draw in a profile of a noisy link trial.
    #[inline(always)]
    pub fn coarse(&self, key: u32) -> u8 {
        self.coarse[key as usize]
    }
}

/// `keep_below`'s top 8 of 31 bits, clamped to a byte (2³¹ itself, "always keep", becomes 255).
/// With the coin's own top 8 bits `h`: `h < coarse` keeps exactly, `h > coarse` drops exactly
/// (then `coarse` is unclamped: `h ≤ 255`), and only `h = coarse` (1 candidate in 256) needs the
/// full bound (`keep_below_decides_as_the_float_test`).
fn coarse_of(keep_below: u32) -> u8 {
    (keep_below >> 23).min(255) as u8
}

impl ShotMap {
    /// The candidate's pixel from its first draw `a`: the column from its high 32 bits, the
    /// alias coin from its low 32.
    #[inline(always)]
    fn pixel(&self, a: u64, pixels: u32) -> u64 {
        let column = column(a, pixels);
        match &self.alias {
            Some(alias) => alias.pixel(column, a & 0xFFFF_FFFF),
            None => column,
        }
    }

    /// Whether the candidate at `pixel` survives the brightness thinning, from bits 1–31 of its
    /// second draw `b` (always, without the term): decided by the pixel's coarse bound
    /// (`keys.coarse`) but for one candidate in 256, which reads its luminance key.
    #[inline(always)]
    fn keeps(&self, b: u64, pixel: u64, keys: &PixelKeys) -> bool {
        if self.keep_below.is_empty() {
            return true;
        }
        let coin = ((b >> 1) & 0x7FFF_FFFF) as u32;
        let (high, coarse) = ((coin >> 23) as u8, keys.coarse[pixel as usize]);
        if high != coarse {
            return high < coarse;
        }
        coin < self.keep_below[keys.luminance[pixel as usize] as usize]
    }
}

/// The pixels' luminance keys at the interval's end and their coarse thinning bounds
/// ([`ShotMap::coarse`] of each key; empty without the brightness term).
#[derive(Clone, Copy)]
pub(super) struct PixelKeys<'a> {
    pub luminance: &'a [u32],
    pub coarse: &'a [u8],
}

/// Multiply-shift: a uniform column below `pixels` from the high 32 bits of `a` (bias below
/// pixels / 2³², negligible for a sensor's pixels).
#[inline(always)]
fn column(a: u64, pixels: u32) -> u64 {
    ((a >> 32) * u64::from(pixels)) >> 32
}

/// One interval's shot events as sortable keys `(t − t0, pixel, polarity)`, packed into a u64
/// (`t − t0` highest), sorted by buckets of their top bits (see [`ShotDraws::sort`]): linear
/// in the count, where a comparison sort of the ≈ 15 000 events of a 10 ms interval at 5 Hz
/// per pixel cost more than drawing them.
#[derive(Clone, Default)]
pub(super) struct ShotDraws {
    pub keys: Vec<u64>,
    scratch: Vec<u64>,
    /// The sort's bucket counters.
    counts: Vec<u32>,
    /// Bits of the pixel index field.
    pixel_bits: u32,
}

impl ShotDraws {
    /// Draws `count` candidates, each at a pixel of `pixels` (uniform or by `map`'s alias), a
    /// uniform integer time offset in `1..=dt` and a fair polarity, keeps each with `map`'s
    /// brightness probability (`keys` are the pixels' keys at the interval's end), and sorts
    /// them by (time, pixel, polarity).
    pub fn draw(
        &mut self,
        rng: &mut ChaCha8Rng,
        count: u64,
        pixels: u32,
        dt: u64,
        map: &ShotMap,
        keys: &PixelKeys,
    ) {
        self.pixel_bits = 32 - pixels.saturating_sub(1).leading_zeros();
        let time_bits = 64 - dt.leading_zeros();
        let bits = time_bits + self.pixel_bits + 1;
        if dt <= u64::from(u32::MAX) {
            self.draw_batched(rng, count, pixels, dt, map, keys);
        } else {
            for _ in 0..count {
                let (a, b) = (rng.next_u64(), rng.next_u64());
                let pixel = map.pixel(a, pixels);
                if map.keeps(b, pixel, keys) {
                    let offset = rng.gen_range(1..=dt);
                    self.keys
                        .push((offset << (self.pixel_bits + 1)) | (pixel << 1) | (b & 1));
                }
            }
        }
        self.sort(bits);
    }

    /// [`ShotDraws::draw`]'s candidates for `dt` within 32 bits (every candidate then uses
    /// exactly two draws), as a pipeline over small batches: while batch n draws its random
    /// numbers and asks for its alias entries, batch n − `RESOLVE_LAG` resolves its pixels and
    /// asks for their coarse thinning bounds, and batch n − `PUSH_LAG` makes its keys. Each
    /// table read thus finds the line asked for several batches of work earlier instead of
    /// waiting for a miss (a 640×480 sensor's alias table is 2.4 MB: beyond L2). The batch and lags were
    /// measured (`cargo bench -p event-camera --bench noise`: 8/4/8 beat 16–32 per batch with
    /// lags 1/2 by 5–10 %, and waiting for each batch's own prefetches by ≈ 20 %). A candidate
    /// is appended without a branch (thinning is a coin flip no predictor can learn). Same
    /// draws, same keys as one candidate at a time (`batched_draws_equal_single_draws`).
    fn draw_batched(
        &mut self,
        rng: &mut ChaCha8Rng,
        count: u64,
        pixels: u32,
        dt: u64,
        map: &ShotMap,
        keys: &PixelKeys,
    ) {
        const BATCH: usize = 8;
        const RESOLVE_LAG: usize = 4;
        const PUSH_LAG: usize = 8;
        const STAGES: usize = PUSH_LAG + 1;
        let mut a = [[0u64; BATCH]; STAGES];
        let mut b = [[0u64; BATCH]; STAGES];
        let mut pixel = [[0u64; BATCH]; STAGES];
        let mut len = [0usize; STAGES];
        let batches = count.div_ceil(BATCH as u64) as usize;
        // Batch n lives in slot n % STAGES; the loop runs PUSH_LAG extra steps to drain it.
        for n in 0..batches + PUSH_LAG {
            if n < batches {
                let s = n % STAGES;
                let m = (count - (n * BATCH) as u64).min(BATCH as u64) as usize;
                len[s] = m;
                for j in 0..m {
                    (a[s][j], b[s][j]) = (rng.next_u64(), rng.next_u64());
                    pixel[s][j] = column(a[s][j], pixels);
                }
                if let Some(alias) = &map.alias {
                    for &c in &pixel[s][..m] {
                        prefetch(&alias.entries, c as usize);
                    }
                }
            }
            if (RESOLVE_LAG..batches + RESOLVE_LAG).contains(&n) {
                let s = (n - RESOLVE_LAG) % STAGES;
                let m = len[s];
                if let Some(alias) = &map.alias {
                    for j in 0..m {
                        pixel[s][j] = alias.pixel(pixel[s][j], a[s][j] & 0xFFFF_FFFF);
                    }
                }
                if !map.keep_below.is_empty() {
                    for &p in &pixel[s][..m] {
                        prefetch(keys.coarse, p as usize);
                    }
                }
            }
            if (PUSH_LAG..batches + PUSH_LAG).contains(&n) {
                let s = (n - PUSH_LAG) % STAGES;
                self.push_keys(&b[s][..len[s]], &pixel[s][..len[s]], dt, map, keys);
            }
        }
    }

    /// Appends the keys of one batch's candidates (second draws `b`, resolved pixels) that
    /// survive the brightness thinning.
    #[inline(always)]
    fn push_keys(&mut self, b: &[u64], pixel: &[u64], dt: u64, map: &ShotMap, keys: &PixelKeys) {
        let start = self.keys.len();
        self.keys.resize(start + b.len(), 0);
        let mut kept = start;
        for (&b, &pixel) in b.iter().zip(pixel) {
            let offset = 1 + (((b >> 32) * dt) >> 32);
            self.keys[kept] = (offset << (self.pixel_bits + 1)) | (pixel << 1) | (b & 1);
            kept += usize::from(map.keeps(b, pixel, keys));
        }
        self.keys.truncate(kept);
    }

    /// Sorts the keys (`bits` wide): a counting sort on their top bits into about one bucket
    /// per key, then one insertion sort over the whole, which only moves keys within their
    /// bucket. Times are uniform, so buckets hold one or two keys: two passes over the keys
    /// where an LSD radix sort made eight.
    fn sort(&mut self, bits: u32) {
        let n = self.keys.len();
        if n < 64 {
            self.keys.sort_unstable();
            return;
        }
        let bucket_bits = (usize::BITS - n.leading_zeros())
            .min(bits)
            .min(MAX_BUCKET_BITS);
        let shift = bits - bucket_bits;
        self.counts.clear();
        self.counts.resize((1 << bucket_bits) + 1, 0);
        for &k in &self.keys {
            self.counts[(k >> shift) as usize + 1] += 1;
        }
        // The running total in a register: summing in place made each step wait for the
        // previous step's store (the draw's hottest line in a perf profile of a noisy trial).
        let mut total = 0;
        for c in &mut self.counts {
            total += *c;
            *c = total;
        }
        self.scratch.resize(n, 0);
        for &k in &self.keys {
            let slot = &mut self.counts[(k >> shift) as usize];
            self.scratch[*slot as usize] = k;
            *slot += 1;
        }
        for i in 1..n {
            let k = self.scratch[i];
            let mut j = i;
            while j > 0 && self.scratch[j - 1] > k {
                self.scratch[j] = self.scratch[j - 1];
                j -= 1;
            }
            self.scratch[j] = k;
        }
        std::mem::swap(&mut self.keys, &mut self.scratch);
    }

    /// (time, pixel index, polarity) of a key of the interval starting at `t0`.
    pub fn unpack(&self, key: u64, t0: u64) -> (u64, u32, Polarity) {
        let pixel = ((key >> 1) & ((1u64 << self.pixel_bits) - 1)) as u32;
        let polarity = if key & 1 == 1 {
            Polarity::On
        } else {
            Polarity::Off
        };
        (t0 + (key >> (self.pixel_bits + 1)), pixel, polarity)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pipelined draw against the plain statement: two draws per candidate, its pixel, its
    /// thinning coin, its key; then a sort. Every stage combination and batch boundary.
    #[test]
    fn batched_draws_equal_single_draws() {
        use rand::SeedableRng;
        let (w, h) = (37u32, 23u32);
        let pixels = w * h;
        let thresholds: Vec<f64> = (0..pixels)
            .map(|i| 0.2 * (1.0 + 0.3 * ((f64::from(i) * 0.7).sin())))
            .collect();
        let luminance: Vec<u32> = (0..pixels).map(|i| (i * 7919) % 255_000).collect();
        let coarse: Vec<Vec<u8>> = [0.0, 0.75]
            .iter()
            .map(|&b| {
                let map = ShotMap::new(0.2, &[0.2], b);
                let per_key = |k: u32| if map.thins() { map.coarse(k) } else { 0 };
                luminance.iter().map(|&k| per_key(k)).collect()
            })
            .collect();
        let maps = [
            ShotMap::new(0.2, &vec![0.2; pixels as usize], 0.0),
            ShotMap::new(0.2, &vec![0.2; pixels as usize], 0.75),
            ShotMap::new(0.2, &thresholds, 0.0),
            ShotMap::new(0.2, &thresholds, 0.75),
        ];
        for (m, map) in maps.iter().enumerate() {
            for count in [0u64, 1, 31, 32, 33, 64, 65, 95, 96, 97, 1_000, 20_011] {
                let dt = 10_000_000;
                let mut rng = ChaCha8Rng::seed_from_u64(count + 17 * m as u64);
                let mut drawn = ShotDraws::default();
                let keys = PixelKeys {
                    luminance: &luminance,
                    coarse: &coarse[m % 2],
                };
                drawn.draw(&mut rng.clone(), count, pixels, dt, map, &keys);
                let mut expected = Vec::new();
                let pixel_bits = 32 - (pixels - 1).leading_zeros();
                for _ in 0..count {
                    let (a, b) = (rng.next_u64(), rng.next_u64());
                    let pixel = map.pixel(a, pixels);
                    // The full bound, as the statement reads: the coarse one decides the same.
                    let coin = ((b >> 1) & 0x7FFF_FFFF) as u32;
                    let key = luminance[pixel as usize] as usize;
                    if map.keep_below.is_empty() || coin < map.keep_below[key] {
                        let offset = 1 + (((b >> 32) * dt) >> 32);
                        expected.push((offset << (pixel_bits + 1)) | (pixel << 1) | (b & 1));
                    }
                }
                expected.sort_unstable();
                assert_eq!(drawn.keys, expected, "map {m}, {count} candidates");
            }
        }
    }

    /// The table against the float test it replaces, at every key and the coins around each
    /// key's boundary and around its coarse bound (and the extremes), for v2e's b and the edge
    /// values of b: the coarse decision and the full bound both decide as the float test.
    #[test]
    fn keep_below_decides_as_the_float_test() {
        for bright_drop in [0.75, 1.0, 0.3, 1e-9] {
            let map = ShotMap::new(0.2, &[0.2], bright_drop);
            for key in 0..=MAX_KEY {
                let y = f64::from(key) / 1000.0;
                let keep = 1.0 - bright_drop * (y + 20.0) / 275.0;
                let bound = map.keep_below[key as usize];
                let coarse = u32::from(map.coarse(key)) << 23;
                let keys = PixelKeys {
                    luminance: &[key],
                    coarse: &[map.coarse(key)],
                };
                for coin in [
                    0,
                    1,
                    bound.saturating_sub(1),
                    bound,
                    bound + 1,
                    coarse.saturating_sub(1),
                    coarse,
                    coarse + (1 << 23) - 1,
                    coarse + (1 << 23),
                    (1 << 31) - 1,
                ] {
                    let coin = coin.min((1 << 31) - 1);
                    let float = f64::from(coin) / f64::from(1u32 << 31) < keep;
                    let b = u64::from(coin) << 1;
                    assert_eq!(
                        map.keeps(b, 0, &keys),
                        float,
                        "b {bright_drop}, key {key}, coin {coin}"
                    );
                }
            }
        }
    }

    #[test]
    fn alias_draws_in_proportion_to_the_weights() {
        let weights = [1.0, 2.0, 0.5, 4.0, 0.5];
        let alias = Alias::new(&weights);
        let total: f64 = weights.iter().sum();
        // Exact probability of each pixel: sum over columns of the kept and aliased shares.
        let n = weights.len() as f64;
        let mut p = [0.0; 5];
        for col in 0..weights.len() {
            let [keep, to] = alias.entries[col];
            // Saturated entries alias to themselves: either way the column's own pixel.
            let keep = f64::from(keep) / (1u64 << 32) as f64;
            p[col] += keep / n;
            p[to as usize] += (1.0 - keep) / n;
        }
        for (i, w) in weights.iter().enumerate() {
            assert!(
                (p[i] - w / total).abs() < 1e-9,
                "{i}: {} vs {}",
                p[i],
                w / total
            );
        }
    }
}
