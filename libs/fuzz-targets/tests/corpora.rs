//! Replays every file of `fuzz/corpus/<target>/` and `fuzz/regressions/<target>/` through its
//! fuzz target, uninstrumented, as part of the default test suite: a parser that panics on a file
//! the fuzzer once found (or on any corpus file) fails here, without a nightly toolchain. A
//! single allocation above 256 MiB aborts the test binary (the cap the campaigns run with), so a
//! length field that sizes an allocation fails here too.
//!
//! Every target must have a non-empty corpus, every `fuzz/fuzz_targets/*.rs` must name a target
//! of `fuzz_targets::TARGETS` and the other way round, and the corpora must stay small.

use std::alloc::{GlobalAlloc, Layout, System};
use std::collections::BTreeSet;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

/// Largest single allocation the replay allows (libFuzzer's `-malloc_limit_mb=256`).
const MAX_ALLOCATION_BYTES: usize = 256 << 20;
/// Largest corpus or regression file kept in the repository.
const MAX_FILE_BYTES: u64 = 64 << 10;
/// Largest total of all corpora and regressions.
const MAX_TOTAL_BYTES: u64 = 2 << 20;

/// The system allocator, refusing any single allocation above [`MAX_ALLOCATION_BYTES`] (Rust
/// then aborts with "memory allocation of N bytes failed").
struct Capped;

// SAFETY: every method forwards to `System` unchanged, except that an oversized request
// returns null, which `GlobalAlloc` allows for any allocation failure.
unsafe impl GlobalAlloc for Capped {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if layout.size() > MAX_ALLOCATION_BYTES {
            return std::ptr::null_mut();
        }
        // SAFETY: the caller's contract for `alloc` is passed on unchanged.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if layout.size() > MAX_ALLOCATION_BYTES {
            return std::ptr::null_mut();
        }
        // SAFETY: the caller's contract for `alloc_zeroed` is passed on unchanged.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `System` through this allocator, with this layout.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > MAX_ALLOCATION_BYTES {
            return std::ptr::null_mut();
        }
        // SAFETY: the caller's contract for `realloc` is passed on unchanged.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Capped = Capped;

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz")
}

/// The files of `dir`, sorted; empty when it does not exist.
fn files(dir: &Path) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut out: Vec<PathBuf> = entries
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.is_file())
        .collect();
    out.sort();
    out
}

#[test]
fn every_corpus_and_regression_file_replays_without_a_panic() {
    let fuzz = fuzz_dir();
    let mut failures = Vec::new();
    let mut replayed = 0;
    for (name, target) in fuzz_targets::TARGETS {
        let corpus = files(&fuzz.join("corpus").join(name));
        if corpus.is_empty() {
            failures.push(format!("{name}: fuzz/corpus/{name}/ is missing or empty"));
        }
        let regressions = files(&fuzz.join("regressions").join(name));
        for file in corpus.iter().chain(&regressions) {
            let bytes = std::fs::read(file).expect("read a corpus file");
            replayed += 1;
            if let Err(panic) = catch_unwind(AssertUnwindSafe(|| target(&bytes))) {
                let why = panic
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| panic.downcast_ref::<&str>().map(|s| (*s).to_owned()))
                    .unwrap_or_default();
                failures.push(format!("{name}: {} panics: {why}", file.display()));
            }
        }
    }
    assert!(replayed > 0, "no corpus file replayed");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn every_fuzz_binary_is_a_target_and_every_target_has_a_binary() {
    let binaries: BTreeSet<String> = files(&fuzz_dir().join("fuzz_targets"))
        .iter()
        .filter_map(|p| Some(p.file_stem()?.to_str()?.to_owned()))
        .collect();
    let targets: BTreeSet<String> = fuzz_targets::TARGETS
        .iter()
        .map(|(n, _)| (*n).to_owned())
        .collect();
    assert_eq!(binaries, targets);
    for name in &binaries {
        let text = std::fs::read_to_string(fuzz_dir().join(format!("fuzz_targets/{name}.rs")))
            .expect("read a fuzz target");
        let call = format!("fuzz_targets::{name}(data)");
        assert!(
            text.contains(&call),
            "fuzz_targets/{name}.rs does not call {call}"
        );
        let cargo = std::fs::read_to_string(fuzz_dir().join("Cargo.toml")).expect("fuzz manifest");
        assert!(
            cargo.contains(&format!("name = \"{name}\"")),
            "fuzz/Cargo.toml has no [[bin]] {name}"
        );
    }
}

#[test]
fn the_corpora_stay_small() {
    let mut total = 0;
    let mut large = Vec::new();
    for kind in ["corpus", "regressions"] {
        let Ok(dirs) = std::fs::read_dir(fuzz_dir().join(kind)) else {
            continue;
        };
        for dir in dirs.flatten() {
            for file in files(&dir.path()) {
                let len = file.metadata().expect("corpus file metadata").len();
                total += len;
                if len > MAX_FILE_BYTES {
                    large.push(format!("{} ({len} bytes)", file.display()));
                }
            }
        }
    }
    assert!(
        large.is_empty(),
        "files over {MAX_FILE_BYTES} bytes:\n{}",
        large.join("\n")
    );
    assert!(total <= MAX_TOTAL_BYTES, "corpora hold {total} bytes");
}

#[test]
fn the_allocation_cap_refuses_what_it_should() {
    let layout = Layout::from_size_align(MAX_ALLOCATION_BYTES + 1, 8).expect("a layout");
    // SAFETY: a non-zero-sized layout; the null result is checked and nothing is freed.
    let p = unsafe { ALLOCATOR.alloc(layout) };
    assert!(p.is_null());
    let small = vec![0u8; 1 << 20];
    assert_eq!(small.len(), 1 << 20);
}
