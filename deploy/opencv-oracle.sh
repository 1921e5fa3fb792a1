#!/usr/bin/env bash
# The OpenCV oracle of the RGB receiver's KLT (a test oracle only: nothing of Waggle runs OpenCV).
# Idempotent: creates third_party/opencv-oracle/venv (git-ignored) with pinned
# opencv-python-headless and numpy wheels from PyPI, once.
#
#   bash deploy/opencv-oracle.sh           set up only; prints the interpreter path
#   bash deploy/opencv-oracle.sh golden    also re-run OpenCV on the fixture and rewrite the
#                                          golden file libs/perception/tests/fixtures/klt/opencv.json
#
# The criterion bench (cargo bench -p perception --bench klt) times OpenCV through this venv
# when it exists. The fixture frames come from
# `cargo run --release -p perception --example klt_fixture`.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="$root/third_party/opencv-oracle/venv"
fixture="$root/libs/perception/tests/fixtures/klt"

OPENCV_VERSION="5.0.0.93"
NUMPY_VERSION="2.4.6"
stamp="$venv/.stamp-opencv-$OPENCV_VERSION-numpy-$NUMPY_VERSION"

say() { printf 'opencv-oracle: %s\n' "$*" >&2; }
die() { printf 'opencv-oracle: error: %s\n' "$*" >&2; exit 1; }

if [ ! -f "$stamp" ]; then
  command -v python3 >/dev/null || die "python3 (>= 3.11, with venv) is needed"
  say "creating $venv with opencv-python-headless==$OPENCV_VERSION numpy==$NUMPY_VERSION"
  rm -rf "$venv"
  python3 -m venv "$venv" || die "python3 -m venv failed (install python3-venv)"
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check --only-binary=:all: \
    "opencv-python-headless==$OPENCV_VERSION" "numpy==$NUMPY_VERSION" \
    || die "could not install the pinned wheels from PyPI"
  "$venv/bin/python" -c 'import cv2, numpy' || die "cv2 does not import in $venv"
  touch "$stamp"
fi

case "${1:-}" in
  "") ;;
  golden)
    [ -f "$fixture/fixture.json" ] || die "no fixture in $fixture (run the klt_fixture example)"
    "$venv/bin/python" "$root/libs/perception/benches/opencv_oracle.py" "$fixture" golden \
      "$fixture/opencv.json"
    ;;
  *) die "unknown argument $1 (want nothing or 'golden')" ;;
esac
echo "$venv/bin/python"
