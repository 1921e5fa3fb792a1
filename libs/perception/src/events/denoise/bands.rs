//! Where the noise filter keeps its map of times, and in what order it visits a packet's events.
//!
//! The whole map of a 640×480 sensor (≈ 4 MB at 12 bytes a pixel) does not fit in one core's L2 cache, so a filter
//! judging the packet's events in their own order sent almost every neighbourhood lookup to L3.
//! The map is therefore cut into horizontal bands of [`BAND_ROWS`] sensor rows, each stored with
//! copies of the r rows above and below it (halo rows; padding at the sensor's top and bottom),
//! and the packet's events are listed band by band, in the packet's order within each band. An
//! event goes into its own band's list and into the list of every neighbouring band whose halo
//! holds its row, flagged [`HALO`] there: it is recorded in that copy but judged only by its own
//! band. Every copy of a pixel thus sees the same events in the same order as the one map did,
//! which is why the banded filter keeps exactly what the one-map filter kept.

use std::ops::Range;

use proto::EventPacket;

/// Sensor rows each band owns. With its halo rows a band of a 640 px sensor is 34 × 642 cells
/// (≈ 260 KB of past and core times, module `times`, and ≈ 175 KB of band scratch): it stays
/// in one core's L2 cache (2 MB here) while the band's events are judged, with the next band's
/// part beside it. Measured (`cargo bench -p perception --bench noise_front_end`, the three
/// alternated): 32 rows ran the front end at 19.6–19.8 M events/s, 16 rows at 17.7–18.8 (an
/// event in a halo row is listed twice, and 16-row bands have twice the halo rows), 64 at
/// 19.3–19.5.
const BAND_ROWS: usize = 32;

/// A band: the first sensor row it owns and where its part of the map starts.
#[derive(Debug, Clone, Copy)]
struct Band {
    y0: usize,
    base: usize,
}

/// Bit 31 of [`Entry`]'s cell: the event belongs to a neighbouring band's edge row and is only
/// recorded in this band's halo copy.
const HALO: u32 = 1 << 31;

/// One event in a band's list: its time (µs), its cell within the band's part of the map (with
/// the [`HALO`] flag) and its index in the packet. 12 bytes: the lists are written once and
/// read three to five times per packet; an index fits in u32 because a packet's events number
/// far below 2³² (a decoded packet is at most 256 MB, `proto`'s message limit).
#[derive(Debug, Clone, Copy)]
pub(super) struct Entry {
    pub t: u32,
    cell: u32,
    index: u32,
}

impl Entry {
    /// Whether the event lies in the band's own rows (judged here), not in its halo.
    pub fn own(&self) -> bool {
        self.cell & HALO == 0
    }

    /// The event's cell in the map, for a band whose part starts at `base` (0: its cell
    /// relative to its band's part).
    pub fn cell(&self, base: usize) -> usize {
        base + (self.cell & !HALO) as usize
    }

    /// The event's index in the packet.
    pub fn index(&self) -> usize {
        self.index as usize
    }
}

/// The bands of one sensor and the current packet's events sorted into them.
#[derive(Debug, Clone)]
pub(super) struct Bands {
    /// Neighbourhood radius: halo rows above and below a band, padding columns on each side.
    r: usize,
    /// Row stride of the map (`width + 2r`).
    stride: usize,
    height: usize,
    bands: Vec<Band>,
    /// The packet's events band by band: band b's are `entries[starts[b]..starts[b + 1]]`.
    entries: Vec<Entry>,
    starts: Vec<usize>,
    cursor: Vec<usize>,
}

impl Bands {
    /// The layout of a `width` × `height` sensor for a neighbourhood of radius `r`; radii up to
    /// [`BAND_ROWS`] (a halo then lies within one neighbouring band).
    pub fn new(width: u16, height: u16, r: usize) -> Self {
        assert!(
            r <= BAND_ROWS,
            "radius {r} exceeds a band's {BAND_ROWS} rows"
        );
        let stride = usize::from(width) + 2 * r;
        let height = usize::from(height);
        let mut bands = Vec::new();
        let mut base = 0;
        for y0 in (0..height).step_by(BAND_ROWS) {
            bands.push(Band { y0, base });
            let rows = BAND_ROWS.min(height - y0);
            base += (rows + 2 * r) * stride;
        }
        Self {
            r,
            stride,
            height,
            bands,
            entries: Vec::new(),
            starts: Vec::new(),
            cursor: Vec::new(),
        }
    }

    /// Row stride of the map.
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// Cells of the whole map: every band with its halo rows and padding columns.
    pub fn cells(&self) -> usize {
        self.bands.last().map_or(0, |b| {
            b.base + (self.height - b.y0 + 2 * self.r) * self.stride
        })
    }

    /// Cells of the largest band's part (what a band-relative scratch needs).
    pub fn band_cells(&self) -> usize {
        (BAND_ROWS.min(self.height) + 2 * self.r) * self.stride
    }

    /// Number of bands.
    pub fn count(&self) -> usize {
        self.bands.len()
    }

    /// Band `b`'s range of [`Bands::entry`] indices and where its part of the map starts.
    pub fn band(&self, b: usize) -> (Range<usize>, usize) {
        (self.starts[b]..self.starts[b + 1], self.bands[b].base)
    }

    pub fn entry(&self, k: usize) -> Entry {
        self.entries[k]
    }

    /// Entry `k`, if there is one (look-ahead past a band's end is harmless).
    pub fn get(&self, k: usize) -> Option<Entry> {
        self.entries.get(k).copied()
    }

    /// The bands an event at row `y` is recorded in: its own, and the neighbouring bands whose
    /// halo holds its row.
    fn bands_of(&self, y: usize) -> (usize, Option<usize>, Option<usize>) {
        let (b, row) = (y / BAND_ROWS, y % BAND_ROWS);
        let above = (row < self.r && b > 0).then(|| b - 1);
        let below = (row + self.r >= BAND_ROWS && b + 1 < self.bands.len()).then_some(b + 1);
        (b, above, below)
    }

    /// Lists the packet's events (those `on_sensor`) by band: a counting sort that keeps the
    /// packet's order within each band.
    pub fn sort(&mut self, packet: &EventPacket, on_sensor: &[bool]) {
        debug_assert!(u32::try_from(packet.len()).is_ok());
        self.starts.clear();
        self.starts.resize(self.bands.len() + 1, 0);
        for (i, &y) in packet.ys.iter().enumerate() {
            if on_sensor[i] {
                let (b, above, below) = self.bands_of(usize::from(y));
                self.starts[b + 1] += 1;
                for halo in [above, below].into_iter().flatten() {
                    self.starts[halo + 1] += 1;
                }
            }
        }
        for b in 0..self.bands.len() {
            self.starts[b + 1] += self.starts[b];
        }
        self.cursor.clear();
        self.cursor.extend_from_slice(&self.starts);
        let total = self.starts.last().copied().unwrap_or(0);
        self.entries.clear();
        self.entries.resize(
            total,
            Entry {
                t: 0,
                cell: 0,
                index: 0,
            },
        );
        let (r, last) = (self.r, self.bands.len().saturating_sub(1));
        for i in 0..packet.len() {
            if !on_sensor[i] {
                continue;
            }
            let (x, y) = (usize::from(packet.xs[i]), usize::from(packet.ys[i]));
            let t = (packet.start_ns.wrapping_add(u64::from(packet.dt_ns[i])) / 1_000) as u32;
            let (b, row) = (y / BAND_ROWS, y % BAND_ROWS);
            // In band k's part, row y sits r + y − y0(k) rows down, y0(k) = k·BAND_ROWS.
            let mut put = |band: usize, rows_down: usize, flag: u32| {
                let cell = rows_down * self.stride + x + r;
                self.entries[self.cursor[band]] = Entry {
                    t,
                    cell: cell as u32 | flag,
                    index: i as u32,
                };
                self.cursor[band] += 1;
            };
            put(b, row + r, 0);
            // A halo row (as `bands_of`): rare, so branches rather than a loop over options.
            if row < r && b > 0 {
                put(b - 1, row + BAND_ROWS + r, HALO);
            }
            if row + r >= BAND_ROWS && b < last {
                put(b + 1, row + r - BAND_ROWS, HALO);
            }
        }
    }
}

/// Asks the CPU to bring the cache line of `slice[index]` towards L1 ahead of use: a hint that
/// changes no result.
#[inline(always)]
pub(super) fn prefetch<T>(slice: &[T], index: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        let p = slice.as_ptr().wrapping_add(index);
        // SAFETY: a prefetch is only a hint: it never faults and reads nothing observable, even
        // at an address outside the slice; SSE is part of the x86_64 baseline.
        unsafe { std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p.cast()) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (slice, index);
}
