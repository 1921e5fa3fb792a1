#!/usr/bin/env bash
# Builds a relocatable bundle of Waggle for compute nodes that have none of its dependencies:
#
#     bash deploy/relocatable.sh OUT_DIR [--strip] [--no-mesa] [--tar]
#
# OUT_DIR/bin/<binary>     wrappers (POSIX sh + readlink): set the environment, exec libexec/…
# OUT_DIR/libexec/<binary> the release binaries, byte-identical (--strip: without debug info)
# OUT_DIR/lib/             libmujoco, glvnd's libEGL, Mesa's libEGL_mesa and every shared library
#                          these and the binaries need, except glibc's (the host provides those)
# OUT_DIR/lib/dri/         Mesa's software driver (llvmpipe), which libEGL_mesa dlopens
# OUT_DIR/share/glvnd/egl_vendor.d/50_mesa.json  the only EGL vendor: the bundled libEGL_mesa
# OUT_DIR/third_party/     the Crazyflie meshes (WAGGLE_THIRD_PARTY), MuJoCo's and their licences
# OUT_DIR/share/doc/<pkg>/ the Debian copyright file of each package a bundled library came from
# OUT_DIR/README           versions (waggle, MuJoCo, Mesa, glvnd, LLVM), the minimum glibc, usage
# OUT_DIR/MANIFEST         sha256 of every file, sorted (cd OUT_DIR && sha256sum -c MANIFEST)
#
# The bundle runs from any path, also through symlinks to its bin/ wrappers; move or copy the
# directory as a whole. --strip removes debug info from the binaries (≈ 0.85 → 0.13 GB), which
# changes their sha256 and so the binary version the lab writes into its records: shards made by
# a stripped bundle merge only with shards made by the same bundle. --no-mesa leaves out EGL,
# Mesa and LLVM (lib/dri/, the vendor file and their libraries): such a bundle renders with
# Waggle's renderer, the default, only; `--render damage|full` (MuJoCo's renderer) needs a bundle
# with Mesa. --tar also writes OUT_DIR.tar.gz.
#
# Inputs (defaults for this checkout): WAGGLE_BIN_DIR (target/release), WAGGLE_THIRD_PARTY
# (third_party/, from deploy/setup.sh), MESA_EGL_VENDOR_JSON (glvnd's Mesa vendor file),
# MESA_DRI_DIR (the dri/ directory beside libEGL_mesa). Idempotent: an existing bundle at OUT_DIR
# is replaced (built beside it, swapped in at the end); any other non-empty OUT_DIR is refused.
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
say() { printf 'relocatable: %s\n' "$*" >&2; }
die() { printf 'relocatable: error: %s\n' "$*" >&2; exit 1; }
usage() { die "usage: bash deploy/relocatable.sh OUT_DIR [--strip] [--no-mesa] [--tar]"; }

BINARIES=(waggle waggle-lab sim-node observer-node performer-node recorder-node scheduler-node)
MARKER=".waggle-relocatable"
FORMAT=1

out="" strip=0 tar=0 mesa=1
for a in "$@"; do
  case "$a" in
    --strip) strip=1 ;;
    --no-mesa) mesa=0 ;;
    --tar) tar=1 ;;
    -h|--help) awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "${BASH_SOURCE[0]}"; exit 0 ;;
    -*) die "unknown option $a (usage: bash deploy/relocatable.sh OUT_DIR [--strip] [--no-mesa] [--tar])" ;;
    *) [ -z "$out" ] || usage; out="$a" ;;
  esac
done
[ -n "$out" ] || usage

for tool in ldd readelf sha256sum ldconfig cp find sort; do
  command -v "$tool" >/dev/null 2>&1 || [ -x "/sbin/$tool" ] || die "$tool is needed (ldd: libc-bin; readelf: binutils; sha256sum: coreutils)"
done
ldconfig_bin="$(command -v ldconfig || echo /sbin/ldconfig)"

bin_dir="${WAGGLE_BIN_DIR:-${CARGO_TARGET_DIR:-$repo/target}/release}"
tp="${WAGGLE_THIRD_PARTY:-$repo/third_party}"

# --- where the bundle goes ---------------------------------------------------------------------
out="$(realpath -m -- "$out")"
case "$out" in
  /|"$repo"|"$repo"/target|"$repo"/target/*|"$bin_dir"|"$bin_dir"/*|"$tp"|"$tp"/*)
    die "refusing to build the bundle at $out (it would overwrite its own inputs)" ;;
esac
case "$out" in *:*) die "$out contains ':', which cannot appear in LD_LIBRARY_PATH" ;; esac
if [ -e "$out" ] || [ -L "$out" ]; then
  if [ ! -d "$out" ] || [ -L "$out" ]; then die "$out exists and is not a directory"; fi
  if [ ! -f "$out/$MARKER" ] && [ -n "$(ls -A -- "$out")" ]; then
    die "$out exists, is not empty and is not a Waggle relocatable bundle (no $MARKER in it): remove it or choose another OUT_DIR"
  fi
fi
mkdir -p -- "$(dirname -- "$out")"
stage="$out.partial-$$"
cleanup() { rm -rf -- "$stage" "$stage.MANIFEST" "$out.tar.gz.partial-$$"; }
trap cleanup EXIT
trap 'exit 130' INT TERM
mkdir -p "$stage"/{bin,libexec,lib,share/doc,third_party}
((mesa)) && mkdir -p "$stage"/{lib/dri,share/glvnd/egl_vendor.d}

# --- inputs, checked before anything is copied -------------------------------------------------
for b in "${BINARIES[@]}"; do
  [ -x "$bin_dir/$b" ] || die "$bin_dir/$b is missing: build the binaries first (cargo build --release --workspace --bins), or set WAGGLE_BIN_DIR"
done
[ -f "$tp/crazyflie/cf2x/cf2x_pcb.stl" ] || die "the Crazyflie meshes are missing in $tp/crazyflie: run bash deploy/setup.sh (or set WAGGLE_THIRD_PARTY)"
for f in LICENSE LICENSES_THIRD_PARTY.md; do
  [ -f "$tp/mujoco/$f" ] || die "MuJoCo's licence file $tp/mujoco/$f is missing: run bash deploy/setup.sh"
done
[ -f "$tp/crazyflie/LICENSE" ] || die "the meshes' licence file $tp/crazyflie/LICENSE is missing: run bash deploy/setup.sh"

case "$(uname -m)" in
  x86_64) ldconfig_arch="x86-64" ;;
  aarch64) ldconfig_arch="AArch64" ;;
  *) ldconfig_arch="$(uname -m)" ;;
esac
# resolve_lib NAME: the path the dynamic loader would use for NAME on this host.
resolve_lib() {
  local p
  p="$("$ldconfig_bin" -p | awk -v n="$1" -v a="$ldconfig_arch" '$1 == n && index($0, a) { print $NF; exit }')"
  [ -n "$p" ] || die "$1 not found by the dynamic loader (ldconfig -p): install the Debian packages of deploy/setup.sh (libegl1 libegl-mesa0 libgl1-mesa-dri libgbm1)"
  printf '%s\n' "$p"
}

egl_mesa_name=""
if ((mesa)); then
# Mesa's glvnd vendor file names its EGL library.
vendor_json="${MESA_EGL_VENDOR_JSON:-}"
if [ -z "$vendor_json" ]; then
  for d in /etc/glvnd/egl_vendor.d /usr/share/glvnd/egl_vendor.d; do
    for j in "$d"/*.json; do
      [ -f "$j" ] && grep -q 'libEGL_mesa' "$j" && { vendor_json="$j"; break 2; }
    done
  done
fi
if [ -z "$vendor_json" ] || [ ! -f "$vendor_json" ]; then
  die "no glvnd EGL vendor file for Mesa (…/glvnd/egl_vendor.d/50_mesa.json): install libegl-mesa0, or set MESA_EGL_VENDOR_JSON"
fi
egl_mesa_name="$(sed -n 's/.*"library_path"[[:space:]]*:[[:space:]]*"\([^"]*\)".*/\1/p' "$vendor_json" | head -n1)"
[ -n "$egl_mesa_name" ] || die "$vendor_json names no library_path"
case "$egl_mesa_name" in
  /*) egl_mesa="$egl_mesa_name"; egl_mesa_name="$(basename "$egl_mesa_name")" ;;
  */*) egl_mesa="$(dirname "$vendor_json")/$egl_mesa_name"; egl_mesa_name="$(basename "$egl_mesa_name")" ;;
  *) egl_mesa="$(resolve_lib "$egl_mesa_name")" ;;
esac
[ -f "$egl_mesa" ] || die "Mesa's EGL library $egl_mesa (from $vendor_json) is missing: install libegl-mesa0"
egl_glvnd="$(resolve_lib libEGL.so.1)"
dri_dir="${MESA_DRI_DIR:-$(dirname "$(readlink -f "$egl_mesa")")/dri}"
[ -f "$dri_dir/swrast_dri.so" ] || die "Mesa's software driver $dri_dir/swrast_dri.so is missing: install libgl1-mesa-dri, or set MESA_DRI_DIR"
fi
libmujoco="$(find "$tp/mujoco/lib" -maxdepth 1 -name 'libmujoco.so.*' -type f | sort | tail -n1)"
[ -n "$libmujoco" ] || die "libmujoco is missing in $tp/mujoco/lib: run bash deploy/setup.sh"

# --- the binaries, MuJoCo, the meshes ----------------------------------------------------------
say "copying the binaries from $bin_dir"
for b in "${BINARIES[@]}"; do
  if ((strip)); then
    strip --strip-debug -o "$stage/libexec/$b" "$bin_dir/$b" || die "strip failed on $bin_dir/$b (binutils)"
  else
    cp -- "$bin_dir/$b" "$stage/libexec/$b"
  fi
  chmod 0755 "$stage/libexec/$b"
done
waggle_version="$("$stage/libexec/waggle" --version 2>/dev/null)" || die "$bin_dir/waggle --version failed"
mujoco_version="${libmujoco##*/libmujoco.so.}"
cp -- "$libmujoco" "$stage/lib/"
mkdir -p "$stage/third_party/mujoco"
cp -- "$tp/mujoco/LICENSE" "$tp/mujoco/LICENSES_THIRD_PARTY.md" "$stage/third_party/mujoco/"
cp -r -- "$tp/crazyflie" "$stage/third_party/crazyflie"
find "$stage/third_party" -name '.stamp-*' -delete

# --- shared libraries: the closure of the binaries and of the dlopened EGL/DRI pieces -------------
# glibc's own libraries stay the host's: they must match its kernel interface and its loader.
is_glibc() {
  case "$1" in
    ld-linux*.so.*|libc.so.*|libm.so.*|libpthread.so.*|libdl.so.*|librt.so.*|libresolv.so.*|\
    libutil.so.*|libanl.so.*|libnsl.so.*|libmvec.so.*|libBrokenLocale.so.*|libthread_db.so.*|\
    libc_malloc_debug.so.*|libnss_*.so.*|libmemusage.so|libpcprofile.so) return 0 ;;
  esac
  return 1
}
declare -A lib_src=()  # bundled name -> host path
declare -A glibc_used=()
add_closure() {  # add_closure FILE: FILE's dependencies, as the loader resolves them
  local f="$1" line name arrow path
  local listing
  listing="$(LD_LIBRARY_PATH="$stage/lib" ldd "$f" 2>&1)" || die "ldd failed on $f: $listing"
  while IFS= read -r line; do
    read -r name arrow path _ <<<"$line" || true
    [ "$arrow" = "=>" ] || continue
    [ "$path" != "not" ] || die "$name, needed by $f, is not installed on this host"
    if is_glibc "$name"; then glibc_used[$name]=1; continue; fi
    [ "$path" = "$stage/lib/$name" ] && continue
    if [ -n "${lib_src[$name]:-}" ] && [ "$(readlink -f "${lib_src[$name]}")" != "$(readlink -f "$path")" ]; then
      die "two different files provide $name: ${lib_src[$name]} and $path"
    fi
    lib_src[$name]="$path"
  done <<<"$listing"
}
say "resolving shared libraries (ldd)"
for b in "${BINARIES[@]}"; do add_closure "$stage/libexec/$b"; done
if ((mesa)); then
  for f in "$egl_glvnd" "$egl_mesa" "$dri_dir/swrast_dri.so"; do add_closure "$f"; done
  lib_src[libEGL.so.1]="$egl_glvnd"
  lib_src[$egl_mesa_name]="$egl_mesa"
fi
for name in "${!lib_src[@]}"; do
  [ "$name" = "${libmujoco##*/}" ] && continue
  cp -L -- "${lib_src[$name]}" "$stage/lib/$name"
done
if ((mesa)); then
# The software device: swrast (llvmpipe), and kms_swrast, the same megadriver under a second name.
cp -L -- "$dri_dir/swrast_dri.so" "$stage/lib/dri/swrast_dri.so"
if [ -f "$dri_dir/kms_swrast_dri.so" ]; then
  if [ "$(stat -Lc %i "$dri_dir/kms_swrast_dri.so")" = "$(stat -Lc %i "$dri_dir/swrast_dri.so")" ]; then
    ln "$stage/lib/dri/swrast_dri.so" "$stage/lib/dri/kms_swrast_dri.so"
  else
    cp -L -- "$dri_dir/kms_swrast_dri.so" "$stage/lib/dri/" && add_closure "$dri_dir/kms_swrast_dri.so"
  fi
fi
# Newer Mesa loads its GBM backends from a directory beside libgbm; this one (22.x) has none.
gbm_dir="$(dirname "$(readlink -f "$egl_mesa")")/gbm"
if [ -d "$gbm_dir" ]; then
  mkdir -p "$stage/lib/gbm"
  for f in "$gbm_dir"/*.so; do [ -f "$f" ] && cp -L -- "$f" "$stage/lib/gbm/" && add_closure "$f"; done
fi
fi
# Anything the closure pass over the DRI/GBM extras added.
for name in "${!lib_src[@]}"; do
  [ -f "$stage/lib/$name" ] || cp -L -- "${lib_src[$name]}" "$stage/lib/$name"
done
chmod -R u+w "$stage/lib"
# Check: every bundled ELF file resolves every dependency inside the bundle or to glibc.
elves=("$stage"/libexec/* "$stage"/lib/*.so*)
((mesa)) && elves+=("$stage"/lib/dri/*.so)
for f in "${elves[@]}"; do
  listing="$(LD_LIBRARY_PATH="$stage/lib" ldd "$f" 2>&1)" || die "ldd failed on $f: $listing"
  while IFS= read -r line; do
    read -r name arrow path _ <<<"$line" || true
    [ "$arrow" = "=>" ] || continue
    is_glibc "$name" && continue
    [ "$path" = "$stage/lib/$name" ] || die "${f#"$stage"/} resolves $name to $path, outside the bundle"
  done <<<"$listing"
done

if ((mesa)); then
cat > "$stage/share/glvnd/egl_vendor.d/50_mesa.json" <<'JSON'
{
    "file_format_version" : "1.0.0",
    "ICD" : {
        "library_path" : "../../../lib/EGL_MESA_NAME"
    }
}
JSON
sed -i "s/EGL_MESA_NAME/$egl_mesa_name/" "$stage/share/glvnd/egl_vendor.d/50_mesa.json"
fi

# --- versions ------------------------------------------------------------------------------------
pkg_version() { dpkg-query -W -f='${Version}' "$1" 2>/dev/null || true; }
have_dpkg=0
command -v dpkg-query >/dev/null 2>&1 && command -v dpkg >/dev/null 2>&1 && have_dpkg=1
mesa_version=""
((have_dpkg && mesa)) && mesa_version="$(pkg_version libegl-mesa0)"
if ((mesa)) && [ -z "$mesa_version" ]; then
  mesa_version="$(grep -aoE -m1 'Mesa [0-9]+\.[0-9]+\.[0-9]+[^ %]*' "$stage/lib/dri/swrast_dri.so" | head -n1 | cut -d' ' -f2 || true)"
fi
((mesa)) || mesa_version="none"
[ -n "$mesa_version" ] || mesa_version="unknown"
glvnd_version=""; ((have_dpkg && mesa)) && glvnd_version="$(pkg_version libegl1)"
llvm_lib="$(find "$stage/lib" -maxdepth 1 -name 'libLLVM*' -printf '%f\n' | head -n1)"

# Packages of the bundled libraries, with their licences.
pkg_table=""
if ((have_dpkg)); then
  # dpkg knows a file by the path its package installed (/lib/… or /usr/lib/… on merged-/usr
  # systems), so ask for each library under every name it has, in one call.
  declare -A pkg_by_path=() src_of=()
  for name in "${!lib_src[@]}"; do src_of[$name]="${lib_src[$name]}"; done
  ((mesa)) && src_of[dri/swrast_dri.so]="$dri_dir/swrast_dri.so"
  candidates=()
  for name in "${!src_of[@]}"; do
    for p in "${src_of[$name]}" "$(readlink -f "${src_of[$name]}")"; do
      candidates+=("$p")
      case "$p" in /usr/*) candidates+=("${p#/usr}") ;; *) candidates+=("/usr$p") ;; esac
    done
  done
  while IFS= read -r line; do
    case "$line" in diversion*|*", "*) continue ;; esac
    pkg_by_path[${line#*: }]="${line%%:*}"
  done < <(dpkg -S "${candidates[@]}" 2>/dev/null || true)
  declare -A pkg_of=()
  for name in "${!src_of[@]}"; do
    owner="?"
    for p in "${src_of[$name]}" "$(readlink -f "${src_of[$name]}")"; do
      for q in "$p" "${p#/usr}" "/usr$p"; do
        [ -n "${pkg_by_path[$q]:-}" ] && { owner="${pkg_by_path[$q]}"; break 2; }
      done
    done
    pkg_of[$name]="$owner"
  done
  for name in $(printf '%s\n' "${!pkg_of[@]}" | LC_ALL=C sort); do
    p="${pkg_of[$name]}"
    pkg_table+="$(printf '  %-28s %-22s %s' "$name" "$p" "$( [ "$p" = "?" ] || pkg_version "$p")")"$'\n'
    if [ "$p" != "?" ] && [ -f "/usr/share/doc/$p/copyright" ] && [ ! -f "$stage/share/doc/$p/copyright" ]; then
      mkdir -p "$stage/share/doc/$p"
      cp -- "/usr/share/doc/$p/copyright" "$stage/share/doc/$p/copyright"
    fi
  done
else
  for name in $(printf '%s\n' "${!lib_src[@]}" | LC_ALL=C sort); do
    pkg_table+="  $name (from ${lib_src[$name]}; no dpkg here, its package and licence were not gathered)"$'\n'
  done
fi

# The newest glibc symbol version any bundled file requires is the bundle's glibc minimum.
glibc_min="2.0" glibc_min_files=""
for f in "$stage"/libexec/* "$stage"/lib/*.so* "$stage"/lib/dri/*.so; do
  v="$(readelf -V -W "$f" 2>/dev/null | grep -oE 'Name: GLIBC_[0-9]+(\.[0-9]+)+' | sed 's/Name: GLIBC_//' | sort -V | tail -n1 || true)"
  [ -n "$v" ] || continue
  rel="${f#"$stage"/}"
  if [ "$v" = "$glibc_min" ]; then
    glibc_min_files+=" $rel"
  elif [ "$(printf '%s\n%s\n' "$glibc_min" "$v" | sort -V | tail -n1)" = "$v" ]; then
    glibc_min="$v" glibc_min_files=" $rel"
  fi
done
interp="$(readelf -l "$stage/libexec/waggle" | sed -n 's/.*interpreter: \(.*\)\]$/\1/p')"
[ -z "$interp" ] || glibc_used[${interp##*/}]=1
glibc_list="$(printf '%s\n' "${!glibc_used[@]}" | LC_ALL=C sort | paste -sd' ')"
host_glibc="$(ldd --version 2>/dev/null | sed -n '1s/.* \([0-9][0-9.]*\)$/\1/p' || true)"
[ -n "$host_glibc" ] || host_glibc="unknown"
os="$(sed -n 's/^PRETTY_NAME="\{0,1\}\([^"]*\)"\{0,1\}$/\1/p' /etc/os-release 2>/dev/null || true)"
[ -n "$os" ] || os="$(uname -sr)"
commit="$(git -C "$repo" rev-parse --short=12 HEAD 2>/dev/null || echo unknown)"
[ "$commit" = unknown ] || git -C "$repo" diff --quiet HEAD -- 2>/dev/null || commit="$commit (with uncommitted changes)"

# --- wrappers ------------------------------------------------------------------------------------
for b in "${BINARIES[@]}"; do
  cat > "$stage/bin/$b" <<SH
#!/bin/sh
# Waggle relocatable bundle (deploy/relocatable.sh): runs libexec/$b with the bundle's MuJoCo,
# Mesa and libraries, wherever the bundle lies (a symlink to this file works too). Children
# (waggle -> waggle-lab, the node processes) are found beside libexec/$b and inherit this.
self=\$(readlink -f -- "\$0") || { echo "$b: cannot resolve \$0 (readlink -f)" >&2; exit 127; }
root=\${self%/*}
root=\${root%/*}
case \$root in *:*) echo "$b: the bundle's path \$root contains ':'; move it" >&2; exit 127 ;; esac
if [ "\${WAGGLE_RELOCATABLE:-}" != "\$root" ]; then
  WAGGLE_HOST_LD_LIBRARY_PATH=\${LD_LIBRARY_PATH:-}
  export WAGGLE_HOST_LD_LIBRARY_PATH
  LD_LIBRARY_PATH=\$root/lib\${LD_LIBRARY_PATH:+:\$LD_LIBRARY_PATH}
  export LD_LIBRARY_PATH
fi
WAGGLE_RELOCATABLE=\$root
__EGL_VENDOR_LIBRARY_FILENAMES=\$root/share/glvnd/egl_vendor.d/50_mesa.json
LIBGL_DRIVERS_PATH=\$root/lib/dri
GBM_BACKENDS_PATH=\$root/lib/gbm
WAGGLE_THIRD_PARTY=\$root/third_party
WAGGLE_MESA_VERSION='$mesa_version'
export WAGGLE_RELOCATABLE __EGL_VENDOR_LIBRARY_FILENAMES LIBGL_DRIVERS_PATH GBM_BACKENDS_PATH \\
  WAGGLE_THIRD_PARTY WAGGLE_MESA_VERSION
exec "\$root/libexec/$b" "\$@"
SH
  chmod 0755 "$stage/bin/$b"
done

# --- README, marker, MANIFEST --------------------------------------------------------------------
size_bin="$(du -sh "$stage/libexec" | cut -f1)"
size_lib="$(du -sh "$stage/lib" | cut -f1)"
cat > "$stage/README" <<README
Waggle relocatable bundle
=========================

$waggle_version, commit $commit$( ((strip)) && echo ", binaries stripped of debug info")
MuJoCo $mujoco_version (lib/libmujoco.so.$mujoco_version; licences in third_party/mujoco/)
$( ((mesa)) && echo "Mesa $mesa_version (EGL: lib/$egl_mesa_name; llvmpipe: lib/dri/swrast_dri.so)" || echo "No Mesa or EGL: cameras render with Waggle's renderer (the default) only")
glvnd ${glvnd_version:-none} (lib/libEGL.so.1), LLVM ${llvm_lib:-none} (Mesa's shader compiler)
Crazyflie meshes: third_party/crazyflie/ (drone-models wheel, MIT; see its LICENSE)
Built on $os (glibc $host_glibc) from $bin_dir.

Requires: Linux x86-64 with glibc >= $glibc_min, /bin/sh and readlink; no GPU, X server, MuJoCo
or Mesa installation. glibc is the host's and is not bundled:
  $glibc_list
so build the bundle on the oldest distribution your nodes run, or use the Apptainer image
(deploy/apptainer/waggle.def), which brings its own. $glibc_min is the newest GLIBC_
symbol version a bundled file requires; these require it:
 $glibc_min_files

Run bin/waggle (or a symlink to it) exactly as target/release/waggle:

    $(basename "$out")/bin/waggle trials --link 011010 --observers 1 --modality rgb --trials 1 --out /tmp/t

Each bin/<binary> is a wrapper that finds its own directory (readlink -f), sets
  LD_LIBRARY_PATH                 lib/ first (the binaries' RUNPATH names the build checkout)
  __EGL_VENDOR_LIBRARY_FILENAMES  share/glvnd/egl_vendor.d/50_mesa.json: only the bundled Mesa
  LIBGL_DRIVERS_PATH              lib/dri: the bundled llvmpipe driver
  GBM_BACKENDS_PATH               lib/gbm: no host GBM backend is ever loaded
  WAGGLE_THIRD_PARTY              third_party/: the meshes
  WAGGLE_RELOCATABLE              the bundle's root (WAGGLE_HOST_LD_LIBRARY_PATH: the value before)
  WAGGLE_MESA_VERSION             $mesa_version
and execs libexec/<binary>. Child processes (waggle execs libexec/waggle-lab; waggle run starts
the node binaries beside it) inherit that environment. Slurm job files: pass
--waggle /ABSOLUTE/PATH/$(basename "$out")/bin/waggle (a path every node sees) to waggle study --slurm.

Sizes: binaries $size_bin, libraries $size_lib. Verify the copy: cd into this directory, then
sha256sum -c --quiet MANIFEST

Bundled libraries (name, Debian package, version; copyright files in share/doc/):
$pkg_table
README
printf 'format %s\n' "$FORMAT" > "$stage/$MARKER"
(cd "$stage" && find . -type f -printf '%P\0' | LC_ALL=C sort -z | xargs -0 sha256sum) > "$stage.MANIFEST"
mv -- "$stage.MANIFEST" "$stage/MANIFEST"

# --- swap in ---------------------------------------------------------------------------------------
rm -rf -- "$out"
mv -- "$stage" "$out"
say "bundle in $out ($(du -sh "$out" | cut -f1); glibc >= $glibc_min; Mesa $mesa_version; MuJoCo $mujoco_version)"
if ((tar)); then
  say "writing $out.tar.gz"
  tar -C "$(dirname "$out")" -czf "$out.tar.gz.partial-$$" "$(basename "$out")"
  mv -- "$out.tar.gz.partial-$$" "$out.tar.gz"
  say "$out.tar.gz ($(du -sh "$out.tar.gz" | cut -f1)), sha256 $(sha256sum "$out.tar.gz" | cut -d' ' -f1)"
fi
