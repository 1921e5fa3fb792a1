#!/usr/bin/env bash
# Runs the `waggle` command line from a fresh machine: installs what it needs (idempotent),
# builds the release binaries, then runs `waggle` with the given arguments.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash deploy/setup.sh
cargo build --release --quiet -p deploy -p lab -p sim-node -p observer-node -p performer-node -p scheduler-node -p recorder-node
exec "$root/target/release/waggle" "$@"
