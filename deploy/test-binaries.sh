#!/usr/bin/env bash
# Runs the workspace's test binaries from the release build, two binaries at a time, the longest
# first, then the doc tests; deploy/test.sh calls it after the build.
#
#   deploy/test-binaries.sh [LIBTEST ARGS…]     e.g. --include-ignored (deploy/test.sh --full)
#
# Why not `cargo test`: it runs one binary after another, and most of the long binaries hold two
# or three whole runs as processes, so a binary's last test leaves a core idle for minutes (the
# test phase used 1.4 of 2 cores, measured on 2026-11-28). Each binary still runs its own tests
# on libtest's default threads, in its package directory as cargo would. Each binary's output is
# printed whole when it ends; every failing binary is named at the end and the exit status is 1.
# WAGGLE_TEST_JOBS sets how many binaries run at once (default 2).
# The tests' scratch directories (and the runs' own, which the launcher puts under the temporary
# directory) go under one TMPDIR made for this run: removed when every test passed, kept and named
# when one failed, so failures can be read and passing runs leave nothing behind (before, each run
# left ≈ 4 MB to 86 MB per test directory in /tmp: 1.3 GB after a day of runs, measured).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
jobs="${WAGGLE_TEST_JOBS:-2}"

work="$(mktemp -d)"
scratch="$(mktemp -d "${TMPDIR:-/tmp}/waggle-tests.XXXXXX")"
keep_scratch=0
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill -- "$p" 2>/dev/null || true; done
  rm -rf "$work"
  if [ "$keep_scratch" -eq 0 ]; then rm -rf "$scratch"; fi
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# Every test target of the workspace: "executable manifest" per line. The build is done, so this
# only lists; a failure here prints cargo's own report.
if ! cargo test --release --workspace --no-run --message-format=json >"$work/artefacts.json" 2>"$work/cargo.err"; then
  cat "$work/cargo.err" >&2
  echo "test-binaries.sh: could not list the test binaries (cargo's report above)" >&2
  exit 1
fi
sed -n 's/.*"manifest_path":"\([^"]*\)".*"profile":{[^}]*"test":true}.*"executable":"\([^"]*\)".*/\2 \1/p' \
  "$work/artefacts.json" >"$work/all"
total="$(wc -l <"$work/all")"
[ "$total" -gt 0 ] || { echo "test-binaries.sh: cargo listed no test binaries" >&2; exit 1; }

# The longest binaries first (wall time on 2 cores, measured 2026-11-30, longest first), so the
# short ones fill the other slot at the end; the rest in cargo's order. A binary missing from
# this list still runs, only later.
longest=(multihost trials frozen link_events hostile sweep view record link_rgb study_shards
  compose mission relocatable delivery_order ingest ros2_export denoise run ros2_live decode
  quic event_receiver link rgb_receiver lab)
: >"$work/order"
for name in "${longest[@]}"; do
  grep -E "/deps/${name}-[0-9a-f]+ " "$work/all" >>"$work/order" || true
done
grep -v -F -f "$work/order" "$work/all" >>"$work/order" || true
export TMPDIR="$scratch"

declare -A label log began
failed=()
timings=()
finish() {
  local pid="$1" status="$2"
  local took_s=$((SECONDS - began[$pid]))
  printf '\n== %s: %s s\n' "${label[$pid]}" "$took_s"
  timings+=("$took_s ${label[$pid]}")
  cat "${log[$pid]}"
  if [ "$status" -ne 0 ]; then failed+=("${label[$pid]}"); fi
}
reap() {
  local done_pid status=0
  wait -n -p done_pid "${pids[@]}" || status=$?
  finish "$done_pid" "$status"
  local keep=()
  for p in "${pids[@]}"; do [ "$p" = "$done_pid" ] || keep+=("$p"); done
  pids=("${keep[@]}")
}

started=0
while read -r exe manifest; do
  while [ "${#pids[@]}" -ge "$jobs" ]; do reap; done
  started=$((started + 1))
  (cd "$(dirname "$manifest")" && exec "$exe" "$@") >"$work/$started.log" 2>&1 &
  pid=$!
  log[$pid]="$work/$started.log"
  began[$pid]=$SECONDS
  label[$pid]="[$started/$total] ${exe#"$root"/} ($(dirname "${manifest#"$root"/}"))"
  pids+=("$pid")
done <"$work/order"
while [ "${#pids[@]}" -gt 0 ]; do reap; done

# Wall seconds per binary, longest first: where the suite's time goes (the order above, and what
# to make faster, comes from this list).
printf '\n== wall seconds per test binary (two at a time), longest first\n'
printf '%s\n' "${timings[@]}" | sort -rn | sed -n 1,12p

printf '\n== doc tests: cargo test --release --workspace --doc\n'
cargo test --release --workspace --doc -- "$@" || failed+=("doc tests")

if [ "${#failed[@]}" -gt 0 ]; then
  keep_scratch=1
  printf '\ntest-binaries.sh: FAILED: %s\n' "${failed[@]}" >&2
  printf 'test-binaries.sh: the tests'"'"' scratch directories are kept in %s\n' "$scratch" >&2
  exit 1
fi
printf '\ntest-binaries.sh: all %s test binaries and the doc tests passed\n' "$total" >&2
