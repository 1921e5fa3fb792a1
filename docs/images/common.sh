# Sourced by the picture scripts, from the repository's root. `picture_bin` prints the directory
# of the waggle binaries: WAGGLE_BIN_DIR if set, else target/release, built through
# deploy/waggle.sh. `picture_venv` makes (on first use) and prints the path of a venv in the
# git-ignored third_party/picture-venv with pinned numpy, mcap (and its zstd and lz4 decoders)
# and Pillow from PyPI. Messages go to standard error; a failure returns non-zero.
picture_bin() {
  local bin
  if [ -n "${WAGGLE_BIN_DIR:-}" ]; then
    bin="$WAGGLE_BIN_DIR"
  else
    bash deploy/waggle.sh --version >/dev/null || return 1
    bin="$PWD/target/release"
  fi
  [ -x "$bin/waggle" ] || { echo "picture: no waggle binary in $bin" >&2; return 1; }
  printf '%s\n' "$bin"
}

picture_venv() {
  local venv="$PWD/third_party/picture-venv"
  local pins=("numpy==2.4.6" "mcap==1.6.0" "zstandard==0.25.0" "lz4==4.4.5" "pillow==11.3.0")
  venv_ok() {
    "$venv/bin/python" - "${pins[@]}" <<'PY' 2>/dev/null
import sys
from importlib.metadata import version
import numpy, mcap.reader, zstandard, lz4.frame, PIL.Image
sys.exit(any(version(p.split("==")[0]) != p.split("==")[1] for p in sys.argv[1:]))
PY
  }
  if ! venv_ok; then
    printf 'picture-venv: installing %s into third_party/picture-venv\n' "${pins[*]}" >&2
    command -v python3 >/dev/null || { echo "picture-venv: python3 (with venv and pip) is needed" >&2; return 1; }
    "$venv/bin/python" -c '' 2>/dev/null || rm -rf "$venv"
    [ -x "$venv/bin/python" ] || python3 -m venv "$venv" \
      || { echo "picture-venv: could not create $venv (Debian: apt-get install python3-venv)" >&2; return 1; }
    "$venv/bin/python" -m pip install --quiet --disable-pip-version-check --only-binary=:all: "${pins[@]}" \
      || { echo "picture-venv: could not install ${pins[*]} from PyPI" >&2; return 1; }
    venv_ok || { echo "picture-venv: $venv still lacks ${pins[*]}" >&2; return 1; }
  fi
  printf '%s\n' "$venv"
}
