#!/usr/bin/env bash
# The test suite from a fresh machine: installs what it needs (idempotent), then runs every test.
#   deploy/test.sh            default suite (≈ 15 min on 2 cores)
#   deploy/test.sh --full     also the long whole-mission tests with sensors (≈ 1 h)
#   deploy/test.sh ARGS…      any other arguments go to `cargo test` (e.g. `-p proto`)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash deploy/setup.sh
if [ "${1:-}" = "--full" ]; then
  exec cargo test --release --workspace -- --include-ignored
fi
if [ "$#" -eq 0 ]; then set -- --workspace; fi
exec cargo test --release "$@"
