"""A receiver written from scratch in plain numpy: an event-camera tracker plug-in.

The performer is where the packet's events are densest: events are binned into 8 px cells,
the cell counts summed over a 5 × 5 neighbourhood, and the centroid of the events around the
best cell is the target's position. While the performer rests it makes (almost) no events, so
the tracker holds its last position: that is what lets Waggle's segmenter confirm the rests
(NULL) between symbols. Everything after the position (segmenter, templates, frame parser) is
Waggle's.

Run it::

    waggle trials --link 011010 --modality events --trials 20 \\
        --receiver python:numpy_tracker:CentroidTracker --out runs/numpy-tracker

with this folder on ``PYTHONPATH``. It need not beat Waggle's receiver; it is an example of the
tracker protocol (``waggle.plugin.Tracker``).
"""

import numpy as np

CELL_PX = 8
MIN_EVENTS = 25
RADIUS_PX = 40.0


class CentroidTracker:
    level = "tracker"

    def __init__(self, info):
        if info.modality != "events":
            raise ValueError(f"CentroidTracker reads an event camera, not {info.modality}")
        self.cols = -(-info.width_px // CELL_PX)
        self.rows = -(-info.height_px // CELL_PX)
        self.last = None

    def reset(self):
        self.last = None

    def push(self, input):
        events = input.events
        if not input.valid or events is None or len(events) < MIN_EVENTS:
            return self.last
        x = events["x"].astype(np.int64)
        y = events["y"].astype(np.int64)
        counts = np.zeros((self.rows + 4, self.cols + 4), dtype=np.int64)
        np.add.at(counts, (y // CELL_PX + 2, x // CELL_PX + 2), 1)
        # A 5 × 5 box sum through cumulative sums: the densest neighbourhood, not one hot pixel.
        c = counts.cumsum(0).cumsum(1)
        c = np.pad(c, ((1, 0), (1, 0)))
        box = c[5:, 5:] - c[:-5, 5:] - c[5:, :-5] + c[:-5, :-5]
        row, col = np.unravel_index(np.argmax(box), box.shape)
        if box[row, col] < MIN_EVENTS:
            return self.last
        centre = np.array([(col + 0.5) * CELL_PX, (row + 0.5) * CELL_PX])
        near = (x - centre[0]) ** 2 + (y - centre[1]) ** 2 <= RADIUS_PX**2
        if near.sum() < MIN_EVENTS:
            return self.last
        self.last = (float(x[near].mean()), float(y[near].mean()))
        return self.last
