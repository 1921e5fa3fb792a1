//! The leak schedule: which pixels may cross upward by a frame's leak value, without judging
//! every pixel every frame.
//!
//! `g` grows with time (it is `leak_hz` times the time since the first frame), so a frame at
//! `g1` need judge only the pixels due by `g1` and those whose input changed. The order in
//! which a frame judges its due pixels does not matter (each is judged by the exact rule;
//! events are sorted afterwards), so a calendar queue of buckets does what a heap did, without
//! its log-time pops over ≈ 300 000 pixels. Entries are never removed early: a pixel judged
//! for another reason gets a new entry and its old one is skipped as stale (its due value no
//! longer lies in that bucket, or it was already handed out).
//!
//! The calendar has two levels. A pixel is rescheduled at every judgement, up to four leak
//! periods ahead; pushing each into one of 16 384 buckets sent every push to a bucket's
//! header and tail lines that were no longer in cache (≈ 100 ns a push in a profile of a noisy
//! trial). Now only the buckets of the current *span* (1/16 of a leak period) are fine; later
//! entries go to one of 64 span buckets, whose few tails stay in cache, together with the due
//! value they were pushed with, and a span's entries are dealt into the fine buckets when the
//! calendar reaches it (by that stored value: placement reads nothing at the entry's pixel;
//! staleness is still judged when an entry is handed out). Entries beyond the span buckets'
//! reach wait in an overflow list. What is handed out by a frame at `g1` is the same as
//! before: every pixel whose live due value is at most `g1`, each once.

use crate::prefetch::prefetch;

/// Width of one fine bucket in leak periods (units of `g`).
const BUCKETS_PER_G: f64 = 4096.0;
/// Fine buckets per span (1/16 of a leak period).
const SPAN: u64 = 256;
/// Span buckets: `SPANS · SPAN / BUCKETS_PER_G` = 4 leak periods ahead.
const SPANS: u64 = 64;
/// How often (in spans) the overflow list is searched for entries within reach: every half of
/// the span buckets' reach, so an entry is placed at least that far before it is due.
const FAR_CHECK_SPANS: u64 = SPANS / 2;
/// How many entries ahead of the one handed out a pop asks for the due value.
const POP_AHEAD: usize = 8;

fn bucket_of(g: f64) -> u64 {
    (g * BUCKETS_PER_G) as u64
}

/// With leak, the pixels grouped by the leak value `g` at which each may next cross upward
/// with its input unchanged.
#[derive(Clone, Default)]
pub(super) struct LeakSchedule {
    /// Due value of each pixel's live entry (∞ once handed out and not yet set again).
    due: Vec<f64>,
    /// The current span's fine buckets (by fine bucket number mod [`SPAN`]).
    fine: Vec<Vec<u32>>,
    /// Later spans' entries with the due value each was pushed with (by span mod
    /// [`SPANS`]).
    spans: Vec<Vec<(u32, f64)>>,
    /// Absolute number of the fine bucket being drained; every earlier bucket is empty.
    cursor: u64,
    /// Entries beyond the span buckets' reach.
    far: Vec<u32>,
    /// Entries of the current bucket not yet due, put back once it is drained.
    later: Vec<u32>,
}

impl LeakSchedule {
    pub fn new(due: impl Iterator<Item = f64>) -> Self {
        let mut schedule = Self {
            fine: vec![Vec::new(); SPAN as usize],
            spans: vec![Vec::new(); SPANS as usize],
            ..Self::default()
        };
        for (i, g) in due.enumerate() {
            schedule.due.push(0.0);
            schedule.set(i, g);
        }
        schedule
    }

    /// Asks for pixel i's due value ahead of [`LeakSchedule::set`].
    #[inline(always)]
    pub fn prefetch(&self, i: usize) {
        prefetch(&self.due, i);
    }

    pub fn set(&mut self, i: usize, g: f64) {
        let g = g.max(0.0);
        self.due[i] = g;
        self.place(i as u32, g);
    }

    /// Puts an entry for pixel `i` due at `g` where the calendar will reach it in time.
    fn place(&mut self, i: u32, g: f64) {
        let b = bucket_of(g).max(self.cursor);
        let (span, now) = (b / SPAN, self.cursor / SPAN);
        if span == now {
            self.fine[(b % SPAN) as usize].push(i);
        } else if span < now + SPANS {
            self.spans[(span % SPANS) as usize].push((i, g));
        } else {
            self.far.push(i);
        }
    }

    /// The next pixel due by `g1` (handed out once), skipping stale entries.
    pub fn pop_due(&mut self, g1: f64) -> Option<usize> {
        let last = bucket_of(g1);
        loop {
            let slot = (self.cursor % SPAN) as usize;
            while let Some(i) = self.fine[slot].pop() {
                if let Some(&ahead) = self.fine[slot]
                    .len()
                    .checked_sub(POP_AHEAD)
                    .map(|k| &self.fine[slot][k])
                {
                    prefetch(&self.due, ahead as usize);
                }
                let d = self.due[i as usize];
                if !d.is_finite() || bucket_of(d) > self.cursor {
                    continue;
                }
                if d > g1 {
                    self.later.push(i);
                    continue;
                }
                self.due[i as usize] = f64::INFINITY;
                return Some(i as usize);
            }
            self.fine[slot].append(&mut self.later);
            if self.cursor >= last {
                return None;
            }
            self.cursor += 1;
            if self.cursor.is_multiple_of(SPAN) {
                self.enter_span();
            }
        }
    }

    /// The cursor has reached a new span: its entries are dealt into the fine buckets, and
    /// now and then the overflow list is searched for entries within the spans' reach.
    fn enter_span(&mut self) {
        let span = self.cursor / SPAN;
        let mut entries = std::mem::take(&mut self.spans[(span % SPANS) as usize]);
        for &(i, g) in &entries {
            // Pushed into this span, so its bucket lies in it (never before the cursor).
            self.fine[(bucket_of(g) % SPAN) as usize].push(i);
        }
        entries.clear();
        self.spans[(span % SPANS) as usize] = entries;
        if span.is_multiple_of(FAR_CHECK_SPANS) && !self.far.is_empty() {
            for i in std::mem::take(&mut self.far) {
                let d = self.due[i as usize];
                // Stale ones (handed out, or set again since) are dropped or re-placed by
                // their live value; a live one comes back within reach in time.
                if d.is_finite() {
                    self.place(i, d);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The schedule against its statement, on dues spread over ten leak periods (many beyond
    /// the span buckets' reach), re-set on the way to later and to earlier values (as a pixel
    /// judged for another reason is), to infinity and to NaN: each frame hands out exactly the
    /// pixels whose live due value is at most the frame's, each once.
    #[test]
    fn each_frame_hands_out_exactly_the_pixels_due_by_it() {
        let n = 5000usize;
        let mut now: Vec<f64> = (0..n)
            .map(|i| (i as f64 * 0.618_034).fract() * 10.0)
            .collect();
        let mut schedule = LeakSchedule::new(now.iter().copied());
        let mut state = 0x2545_F491_4F6C_DD1Du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let mut g = 0.0;
        while g < 12.0 {
            g += 0.001 + (next() % 1000) as f64 * 1e-5;
            let mut handed = Vec::new();
            while let Some(i) = schedule.pop_due(g) {
                handed.push(i);
            }
            handed.sort_unstable();
            let mut due: Vec<usize> = (0..n).filter(|&i| now[i] <= g).collect();
            due.sort_unstable();
            assert_eq!(handed, due, "at g = {g}");
            for &i in &handed {
                now[i] = f64::INFINITY;
            }
            for _ in 0..next() % 40 {
                let i = next() as usize % n;
                let value = match next() % 10 {
                    0 => f64::INFINITY,
                    1 => f64::NAN,
                    2 => g - 0.5,
                    3 => g + 0.000_1,
                    k => g + (next() % 100_000) as f64 * 1e-4 * k as f64,
                };
                schedule.set(i, value);
                // As `set` reads it: NaN and below zero are due at 0; a value already passed
                // is due at the next frame.
                now[i] = if value.is_nan() { 0.0 } else { value.max(0.0) };
            }
        }
    }
}
