"""Decodes a `waggle inputs` stream with Waggle's own receivers, from Python, and prints per
observer what a trial record holds (released payloads, token count, events received), plus the
stream's ground truth in brief. Used by tests/tests/plugins.rs."""

import json
import sys

import numpy as np
import waggle
from waggle.inputs import read_inputs

inputs = read_inputs(sys.argv[1])
receivers = {}
for info in inputs.observers:
    cls = waggle.EventReceiver if inputs.modality == "events" else waggle.RgbReceiver
    receivers[info.name] = cls((*info.home_m, info.yaw_rad, info.pitch_rad), info.rectification)
out = {o.name: {"released": [], "tokens": 0, "ticks": 0, "seen": 0} for o in inputs.observers}
for tick in inputs:
    rx, rec = receivers[tick.observer], out[tick.observer]
    rx.set_ego_rotation(tick.ego)
    if tick.kind == "events":
        step = rx.push(tick.events, tick.start_ns, tick.end_ns, tick.seq, tick.valid, tick.continuous)
    else:
        step = rx.push(tick.frame, tick.end_ns, tick.seq, tick.valid, tick.continuous)
    rec["tokens"] += len(step.tokens)
    rec["released"] += [format(payload, "06b") for payload, _ in step.frames]
    rec["ticks"] += 1
    rec["seen"] += tick.performer_px is not None
for name, rx in receivers.items():
    if inputs.modality == "events":
        out[name]["events_received"] = rx.counts()["events_received"]
labels = inputs.labels_at(np.array([s.start_ns for s in inputs.timeline]))
print(json.dumps({
    "observers": out,
    "ideal": {k: [f[0] for f in v["frames"]] for k, v in inputs.ideal.items()},
    "symbols": sorted({s.symbol for s in inputs.timeline}),
    "labels_match_timeline": [int(c) for c in labels] == [
        ["NULL", "START", "BIT0", "BIT1", "END", "UNKNOWN", "ACQUISITION"].index(s.symbol)
        for s in inputs.timeline
    ],
}))
