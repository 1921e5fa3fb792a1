#!/usr/bin/env bash
# One session on two hosts: host `a` runs the router, simulator, scheduler, performer and
# recorder; host `b` every camera and observer. ROUTER is an address b reaches (a's address).
# This writes the compose file and one directory per host to copy there; then run, on each host,
# the `waggle up` line it prints (b may start first: its nodes dial until the router is up).
#
#   examples/two-hosts.sh [OUT_DIR] [ROUTER]     (WAGGLE: the waggle to run)
set -euo pipefail
waggle="${WAGGLE:-waggle}"
out="${1:-runs/two-hosts}"
router="${2:-quic/192.168.1.10:7447}"
mkdir -p "$out"
"$waggle" compose one-observer --modality rgb \
  --place '*=a' --place 'camera-*=b' --place 'observer-*=b' \
  --router "$router" --out "$out/session.toml"
for host in a b; do
  "$waggle" bundle "$out/session.toml" --host "$host" --out "$out/host-$host"
  echo "on $host: waggle up $out/host-$host/session.toml --host $host --out run-$host"
done
