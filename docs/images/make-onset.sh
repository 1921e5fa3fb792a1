#!/usr/bin/env bash
# Regenerates docs/images/bit0-onset.png: why a `BIT0` comes out `?` on Waggle's renderer and
# not on MuJoCo's under a slow photoreceptor (the one difference of the renderer studies).
#
#   bash docs/images/make-onset.sh
#
# Flies one event link per renderer (`waggle link`, a few seconds each) with the same seed and
# sensor terms, writing the camera's events (`--events-raw`); replays each recording through the
# event receiver (the perception crate's `event_symbols` example), which names every packet's
# tracker verdict and its window's ON/OFF counts; make_onset.py draws the packets around the
# first interruption. Seed, terms and renderers are fixed here, so a rerun writes the same bytes.
#
# Binaries: target/release, built through deploy/waggle.sh; WAGGLE_BIN_DIR=DIR uses DIR's.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$root"

SEED=4
TERMS=(--sensor-preset v2e-default --perturb events.cutoff_hz=30 --perturb events.shot_noise_hz=0.201)
OUT="docs/images/bit0-onset.png"

say() { printf 'make-onset: %s\n' "$*" >&2; }
die() { say "$*"; exit 1; }

# shellcheck source=docs/images/common.sh
source docs/images/common.sh
bin="$(picture_bin)"
cargo build --release --quiet -p perception --example event_symbols
symbols="$root/target/release/examples/event_symbols"

venv="$(picture_venv)"

tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

for render in raster damage; do
  say "flying the link on the $render renderer (seed $SEED)"
  "$bin/waggle" link --payload 011010 --observers 1 --modality events "${TERMS[@]}" \
    --seed "$SEED" --render "$render" --json --events-raw "$tmp/$render" >"$tmp/$render.json" \
    2>"$tmp/$render.err" || { cat "$tmp/$render.err" >&2; die "waggle link ($render) failed"; }
  "$symbols" "$tmp/$render/O1.raw" --packets "$tmp/$render.packets.csv" >"$tmp/$render.tokens"
done
# The packets around the first one-sided window on Waggle's renderer (the track put in doubt,
# or interrupted), and their raw events.
end_ns="$(awk -F, 'NR > 1 && ($7 == "OneSidedPolarity" || $NF != "") { print $1; exit }' \
  "$tmp/raster.packets.csv")"
[ -n "$end_ns" ] || die "no one-sided window on the raster renderer: nothing to draw"
from_ns=$((end_ns - 120000000))
to_ns=$((end_ns + 40000000))
for render in raster damage; do
  "$symbols" "$tmp/$render/O1.raw" --events "$from_ns:$to_ns:$tmp/$render.events.csv" >/dev/null
done
"$venv/bin/python" docs/images/make_onset.py "$tmp" "$end_ns" "$OUT"
