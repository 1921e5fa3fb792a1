//! Bounded resources: every target's parser, fed its corpus with length and count fields made
//! huge, allocates at most a fixed bound at once, measured with a counting allocator. This file
//! is its own test binary with one test, so nothing else allocates beside it.
//!
//! The bound is [`BOUND_BYTES`] (4 MiB: four times the largest message Waggle's own writers put
//! on the bus, a 640×480 RGB key frame of 0.9 MB) for every parser, and for the compressed
//! containers (MCAP recordings and bags) the documented cap on a chunk's declared uncompressed
//! size, [`recording::records::CHUNK_LIMIT_BYTES`], on top: a chunk's buffer is sized by what it
//! declares once that is checked against the cap. The inputs are a few kilobytes each.

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Counts the bytes live and the most live since the last [`reset_peak`].
struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

fn grew(size: usize) {
    let live = LIVE.fetch_add(size, Ordering::Relaxed) + size;
    PEAK.fetch_max(live, Ordering::Relaxed);
}

// SAFETY: every call is passed to the system allocator unchanged; only counters are added.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's layout, as GlobalAlloc requires.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            grew(layout.size());
        }
        p
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: as above.
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            grew(layout.size());
        }
        p
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: ptr came from this allocator with this layout.
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: as above.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
            grew(new_size);
        }
        p
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// What a length or count field is set to.
const HUGE: [u64; 4] = [u64::MAX, 0xFFFF_FFFF, 0x7FFF_FFFF, 0x0100_0000];
/// At most this many bytes live at once for any parser of any input tried here.
const BOUND_BYTES: usize = 4 << 20;
/// Targets whose input holds compressed chunks.
const CHUNKED: [&str; 2] = ["recording", "ros2_bag"];
/// Files per target and field positions per file tried.
const FILES: usize = 4;
const POSITIONS: usize = 192;

/// The corpus files of `target` tried: the largest (the most structure), name order on ties.
fn files(target: &str) -> Vec<Vec<u8>> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fuzz/corpus")
        .join(target);
    let mut found: Vec<(usize, String, Vec<u8>)> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| {
            let path = e.unwrap().path();
            let bytes = std::fs::read(&path).unwrap();
            (bytes.len(), path.display().to_string(), bytes)
        })
        .collect();
    found.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)));
    found.into_iter().take(FILES).map(|f| f.2).collect()
}

/// The most bytes live at once while `run` ran, beyond what was live before it.
fn peak_of(run: impl FnOnce()) -> usize {
    let before = LIVE.load(Ordering::Relaxed);
    PEAK.store(before, Ordering::Relaxed);
    run();
    PEAK.load(Ordering::Relaxed).saturating_sub(before)
}

/// The recording's path-based reader of its leading metadata (`waggle replay`, `export`), fed
/// a file whose first record claims 512 MiB of which 4 bytes follow.
fn leading_record_longer_than_its_file() -> usize {
    let dir = std::env::temp_dir().join(format!("waggle-leading-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("claims-half-a-gigabyte.mcap");
    // The magic, then a metadata record (opcode 0x0C) claiming 512 MiB.
    let mut bytes = b"\x89MCAP0\r\n".to_vec();
    bytes.push(0x0C);
    bytes.extend_from_slice(&(512u64 << 20).to_le_bytes());
    bytes.extend_from_slice(&[0; 4]);
    std::fs::write(&path, &bytes).unwrap();
    let mut got = None;
    let peak = peak_of(|| got = Some(recording::leading_metadata(&path, "session")));
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(
        matches!(got, Some(Err(recording::ReadError::NotMcap { .. }))),
        "{got:?}"
    );
    peak
}

#[test]
fn huge_length_fields_allocate_at_most_the_bound() {
    let mut report = Vec::new();
    for (target, run) in fuzz_targets::TARGETS {
        let mut worst = (0usize, 0usize, 0usize, 0u64);
        for (k, file) in files(target).iter().enumerate() {
            let step = (file.len() / POSITIONS).max(1);
            for at in (0..file.len()).step_by(step) {
                for huge in HUGE {
                    for width in [4usize, 8] {
                        if at + width > file.len() {
                            continue;
                        }
                        let mut input = file.clone();
                        input[at..at + width].copy_from_slice(&huge.to_le_bytes()[..width]);
                        let peak = peak_of(|| run(&input));
                        if peak > worst.0 {
                            worst = (peak, k, at, huge);
                        }
                    }
                }
            }
        }
        report.push((target, worst));
    }
    let mut over = Vec::new();
    let leading = leading_record_longer_than_its_file();
    eprintln!("recording::leading_metadata: peak {leading} B");
    if leading > BOUND_BYTES {
        over.push(format!(
            "recording::leading_metadata: {leading} B > {BOUND_BYTES} B"
        ));
    }
    for (target, (peak, k, at, huge)) in &report {
        eprintln!("{target}: peak {peak} B (file {k}, field at {at} = {huge:#x})");
        let bound = if CHUNKED.contains(target) {
            BOUND_BYTES + recording::records::CHUNK_LIMIT_BYTES
        } else {
            BOUND_BYTES
        };
        if *peak > bound {
            over.push(format!(
                "{target}: {peak} B > {bound} B (file {k}, field at {at} = {huge:#x})"
            ));
        }
    }
    assert!(
        over.is_empty(),
        "allocations over the bound:\n{}",
        over.join("\n")
    );
}
