#!/usr/bin/env bash
# The test suite from a fresh machine: installs what it needs (idempotent), checks the code, then
# runs every test. This is the README's test command and what CI runs (.ci/run).
#
#   deploy/test.sh            default suite (held under 30 min on 2 cores, build included; where
#                             the time goes: docs/decisions/test-time-budget.md; run as root:
#                             the multi-host tests make network namespaces)
#   deploy/test.sh --full     also the long `#[ignore]`d tests: whole missions as processes with
#                             sensors, the frozen-behaviour runs of nominal-3 and dropout-o2 (and
#                             of only-a on the reference `--render full` path), only-a with RGB
#                             as one-process mission, the RGB link's six-payload sweep, a
#                             study in shards killed and resumed, and a study as a job array on a
#                             real Slurm (tests/tests/slurm.rs: installs slurm-wlm and munge once,
#                             starts its own slurmctld, slurmd and munged from a generated
#                             configuration in a temporary directory, removes it after), the
#                             long-hour case's memory over 3 900 s of sim time (≈ 9 min) and the
#                             soak of 50 faulted `only-a` runs on namespace hosts (≈ 17 min;
#                             WAGGLE_SOAK_RUNS, WAGGLE_SOAK_SEED) (≈ 1.5 h)
#   deploy/test.sh ARGS…      any other arguments go to `cargo test --release` instead of
#                             `--workspace` (e.g. `-p proto`, or `-p waggle-tests --test run`)
#
# Steps, in order; the first that fails stops the script with a line saying what to do:
#   1. setup        deploy/setup.sh (Debian packages, MuJoCo, meshes; cached)
#   2. format       cargo fmt --all --check
#   3. audit        cargo-deny (setup.sh's pinned prebuilt binary; elsewhere built once, ≈ 6 min): bans, licenses and sources (deny.toml)
#                   offline; advisories only when the RustSec database (GitHub) is reachable,
#                   otherwise a line says they were skipped
#   4. build        every binary, test and example (the cross-process tests in tests/ run the
#                   binaries by path); benches are checked by clippy, built by `cargo bench`
#   5. clippy       cargo clippy --workspace --all-targets --release -D warnings (after the build,
#                   whose build-script outputs it reuses; it checks every dependency again in
#                   check mode, ≈ 217 of its ≈ 267 core-s, which no cargo option shares)
#   6. docs         with --full only: cargo doc --workspace --no-deps, rustdoc warnings denied
#   7. test         deploy/test-binaries.sh: the test binaries two at a time, then the doc
#                   tests (cargo test --release ARGS… when other arguments are given)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

# The version deny.toml is written for (setup.sh pins the same release's prebuilt binary).
CARGO_DENY_VERSION="0.20.2"

step() { printf '\n== test.sh: %s (%s)\n' "$1" "$(date +%H:%M:%S)" >&2; }
fail() {
  printf '\ntest.sh: FAILED: %s\n' "$1" >&2
  exit 1
}

step "setup"
bash deploy/setup.sh

step "format: cargo fmt --all --check"
cargo fmt --all --check ||
  fail "formatting differs from rustfmt (diff above): run \`cargo fmt --all\` and commit the result"

step "audit: cargo deny (deny.toml)"
# setup.sh puts the pinned prebuilt cargo-deny here (x86_64); elsewhere it is built once.
export PATH="$root/third_party/tools/bin:$PATH"
if [ "$(cargo deny --version 2>/dev/null)" != "cargo-deny $CARGO_DENY_VERSION" ]; then
  echo "test.sh: installing cargo-deny $CARGO_DENY_VERSION (once; ≈ 6 min on 2 cores)" >&2
  cargo install --locked --version "$CARGO_DENY_VERSION" cargo-deny ||
    fail "could not install cargo-deny (crates.io unreachable?)"
fi
# cargo-deny reads the metadata of every platform's dependencies; a fresh machine has downloaded
# only this platform's, so fetch the rest first (crates.io; cached after the first run).
cargo fetch --locked >/dev/null ||
  fail "could not fetch the locked dependencies (crates.io unreachable?)"
cargo deny --offline --log-level error check bans licenses sources ||
  fail "dependency audit (bans, licenses, sources) failed: see the report above and deny.toml"
# The advisory database is a git repository on GitHub; where it cannot be fetched (CI has no
# GitHub), say so rather than fail or silently pass.
if timeout 300 cargo deny fetch db >/dev/null 2>&1; then
  cargo deny --offline --log-level error check advisories ||
    fail "security advisories affect the dependency tree: see the report above; accept one only in deny.toml with a reason"
else
  echo "test.sh: advisory database unreachable: skipped (cargo deny check advisories)" >&2
fi

step "build: cargo build --release --workspace --lib --bins --tests --examples"
# The cross-process tests in tests/ spawn the binaries; `cargo test` only builds the binaries of
# the package under test, so build every one first. One build for binaries and tests: tests
# resolve features with the dev-dependencies (proptest, criterion), which add features to shared
# dependencies (zerocopy, regex-syntax), so building the binaries alone first compiled the Zenoh
# stack and every crate above it twice (79 crates, ≈ 6 min of a fresh clone's 63 min).
# Benches are not built here (criterion and the 7 bench binaries: ≈ 57 core-s of the build,
# measured with --timings on 2026-11-30); the clippy step below type-checks and lints them, and
# `cargo bench` builds them when they are run.
cargo build --release --workspace --lib --bins --tests --examples ||
  fail "the workspace does not build (errors above)"

step "clippy: cargo clippy --workspace --all-targets --release -- -D warnings"
cargo clippy --workspace --all-targets --release -- -D warnings ||
  fail "clippy reports warnings (denied, above): fix them, or \`#[expect(lint, reason = \"…\")]\` where the lint is wrong"

if [ "${1:-}" = "--full" ]; then
  # About a minute more than the default run's budget allows; the links it checks change rarely.
  step "docs: cargo doc --workspace --no-deps with rustdoc warnings denied"
  RUSTDOCFLAGS="-D warnings" cargo doc --release --workspace --no-deps ||
    fail "rustdoc reports warnings (denied, above): fix the doc links or the HTML in doc comments"
fi

step "test"
# The default and --full runs go through deploy/test-binaries.sh: every test binary, two at a
# time, longest first (why: there). Any other arguments are cargo test's.
if [ "$#" -eq 0 ]; then
  exec bash deploy/test-binaries.sh
fi
if [ "$1" = "--full" ]; then
  exec bash deploy/test-binaries.sh --include-ignored
fi
exec cargo test --release "$@"
