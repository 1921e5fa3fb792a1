#!/usr/bin/env bash
# The test suite from a fresh machine: installs what it needs (idempotent), then runs every test.
#   deploy/test.sh            default suite (≈ 15 min on 2 cores)
#   deploy/test.sh --full     also the long whole-mission tests with sensors (≈ 1 h)
#   deploy/test.sh ARGS…      any other arguments go to `cargo test` (e.g. `-p proto`)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash deploy/setup.sh
# The cross-process tests in deploy/tests spawn the node binaries; `cargo test` only builds the
# binaries of the package under test, so build every node first.
cargo build --release --workspace --bins
if [ "${1:-}" = "--full" ]; then
  exec cargo test --release --workspace -- --include-ignored
fi
if [ "$#" -eq 0 ]; then set -- --workspace; fi
exec cargo test --release "$@"
