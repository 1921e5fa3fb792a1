#!/usr/bin/env bash
# Regenerates docs/images/scene-and-events.png, the README's picture: observer O1's camera
# during the one-observer case's first broadcast, its RGB render beside the events its
# event sensor produced over the 20 ms before it.
#
#   bash docs/images/make-picture.sh
#
# Flies the case as processes with an event camera (`waggle run`, about a minute), recording
# the sensor's input (its renders); `waggle export ros2` regenerates the sensor's packets from
# that input; make_picture.py decodes both and composes the PNG. Case, seed, render path and
# window are fixed here, so a rerun writes the same bytes.
#
# Binaries: target/release, built through deploy/waggle.sh (setup and build, as the README's
# first command); WAGGLE_BIN_DIR=DIR uses the binaries in DIR instead and builds nothing.
# Python: a venv in the git-ignored third_party/picture-venv with pinned numpy, mcap (and its
# zstd and lz4 decoders) and Pillow from PyPI, made on first use.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$root"

CASE="one-observer"
SEED=0
END_S="19.40"   # mid-way through the START symbol that opens round 1's first offer
WINDOW_MS=20
OUT="docs/images/scene-and-events.png"

say() { printf 'make-picture: %s\n' "$*" >&2; }
die() { say "$*"; exit 1; }

# shellcheck source=docs/images/common.sh
source docs/images/common.sh
bin="$(picture_bin)"

venv="$(picture_venv)"

tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

say "flying $CASE with an event camera (waggle run, about a minute)"
"$bin/waggle" run "$CASE" --modality events --render raster --seed "$SEED" \
  --record-events input --bin-dir "$bin" --out "$tmp/run" --quiet >"$tmp/run.txt" 2>&1 \
  || { cat "$tmp/run.txt" >&2; die "waggle run $CASE failed"; }
say "regenerating its event packets (waggle export ros2)"
"$bin/waggle" export ros2 "$tmp/run" --out "$tmp/bag" >"$tmp/export.txt" 2>&1 \
  || { cat "$tmp/export.txt" >&2; die "waggle export ros2 failed"; }
"$venv/bin/python" docs/images/make_picture.py "$tmp/run" "$tmp/bag" "$OUT" \
  --end-s "$END_S" --window-ms "$WINDOW_MS"
