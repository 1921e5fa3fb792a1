#!/usr/bin/env bash
# The test suite from a fresh machine: installs what it needs (idempotent), then runs every test.
# Extra arguments go to `cargo test` (e.g. `deploy/test.sh -p proto`).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash deploy/setup.sh
if [ "$#" -eq 0 ]; then set -- --workspace; fi
exec cargo test --release "$@"
