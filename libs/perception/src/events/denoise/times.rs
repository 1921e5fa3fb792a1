//! The noise filter's memory of when pixels fired, as microseconds (wrapping u32).
//!
//! Three arrays, one per kind of time, because each of the filter's passes reads one kind only:
//! a neighbourhood lookup then touches three short runs of one array, and a band's persistent
//! times take 12 bytes a cell instead of the 20 of one record holding all five times (fewer
//! cache lines to bring in on a band's first pass: `cargo bench -p perception --bench
//! noise_front_end`). The later-event times live only inside one band's backward pass, so they
//! are one band-sized scratch that every band reuses and that therefore stays in cache.

use super::{MAX_DEPTH, STALE_US};

/// The filter's times.
#[derive(Debug, Clone, Default)]
pub(super) struct Times {
    /// Per cell of the banded map: the pixel's latest and second-latest events so far.
    pub past: Vec<[u32; MAX_DEPTH]>,
    /// Per cell of the banded map: its latest core event so far (with borders).
    pub core: Vec<u32>,
    /// Per cell of one band (band-relative): inside a backward pass, the pixel's earliest and
    /// second-earliest later events of this packet. Every band clears what it wrote.
    pub next: Vec<[u32; MAX_DEPTH]>,
}

/// A time out of reach of `now_us` and of everything up to [`STALE_US`] after it.
pub(super) fn never(now_us: u32) -> u32 {
    now_us.wrapping_sub(STALE_US)
}

impl Times {
    /// Whether nothing has been stored yet.
    pub fn is_empty(&self) -> bool {
        self.past.is_empty()
    }

    /// `cells` of map and `band_cells` of scratch, nothing in reach of `now_us`.
    pub fn reset(&mut self, cells: usize, band_cells: usize, now_us: u32) {
        let never = never(now_us);
        self.past.clear();
        self.past.resize(cells, [never; MAX_DEPTH]);
        self.core.clear();
        self.core.resize(cells, never);
        self.next.clear();
        self.next.resize(band_cells, [never; MAX_DEPTH]);
    }

    /// Ages every time older than [`STALE_US`] at `now_us` to exactly that, so that wrapping
    /// subtraction keeps reading every stored age right.
    pub fn sweep(&mut self, now_us: u32) {
        let never = never(now_us);
        let age = |t: &mut u32| {
            if now_us.wrapping_sub(*t) > STALE_US {
                *t = never;
            }
        };
        self.past.iter_mut().flatten().for_each(age);
        self.core.iter_mut().for_each(age);
        self.next.iter_mut().flatten().for_each(age);
    }
}
