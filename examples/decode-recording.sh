#!/usr/bin/env bash
# Decode an event recording with an observer's receiver, as `waggle decode` does for a real
# camera's file. With no FILE, a link writes one first: the performer flies 101001 and O1's event
# camera is written as Prophesee EVT 3.0, seen from 15° left, 5° up, 1.6 m away; decoding it from
# the same viewpoint gives the live link's payload. With FILE (EVT 3.0 or 2.0 `.raw`, DAT,
# AEDAT4, a ROS 2 bag), that file is decoded from the same viewpoint.
#
#   examples/decode-recording.sh [OUT_DIR] [FILE]     (WAGGLE: the waggle to run)
set -euo pipefail
waggle="${WAGGLE:-waggle}"
out="${1:-runs/decode}"
file="${2:-}"
viewpoint="--viewpoint=-15,5,1.6"
mkdir -p "$out"
if [ -z "$file" ]; then
  "$waggle" link --modality events "$viewpoint" --payload 101001 --events-raw "$out"
  file="$out/O1.raw"
fi
"$waggle" decode --events "$file" "$viewpoint"
