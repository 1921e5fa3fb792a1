"""Decodes an EVT 3.0 .raw file with the independent PyPI `evt3` decoder and prints, as JSON,
its geometry, event count and an order-sensitive checksum of (t_us, x, y, polarity), which the
Rust cross-check (tests/tests/evt3.rs) computes the same way from the events it wrote."""
import json
import sys

import evt3
import numpy as np

events = evt3.decode_file(sys.argv[1])
t = np.asarray(events.timestamp, dtype=np.uint64)
x = np.asarray(events.x, dtype=np.uint64)
y = np.asarray(events.y, dtype=np.uint64)
p = np.asarray(events.polarity, dtype=np.uint64)
i = np.arange(1, len(t) + 1, dtype=np.uint64)
with np.errstate(over="ignore"):
    check = int(((t * np.uint64(1_000_003) + x * np.uint64(1009) + y * np.uint64(17) + p) * i).sum(dtype=np.uint64))
print(json.dumps({"width": int(events.sensor_width), "height": int(events.sensor_height),
                  "events": int(len(t)), "checksum": check,
                  "last_t_us": int(t[-1]) if len(t) else None}))
