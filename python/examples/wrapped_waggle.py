"""Waggle's own receivers wrapped as full-receiver plug-ins (``waggle.plugin.FullReceiver``).

Scored by ``waggle trials --receiver python:wrapped_waggle:WaggleEvents`` (or ``WaggleRgb``),
they give the native run's ``trials.json`` byte for byte: the plug-in gets the very inputs
Waggle's receiver gets, and builds the receiver exactly as an observer does. A starting point
for wrapping: change what goes in (filter events, crop frames) or what comes out, and compare.
"""

import waggle
from waggle.plugin import FullStep


def _placement(info):
    return (*info.home_m, info.yaw_rad, info.pitch_rad)


class WaggleEvents:
    level = "full"

    def __init__(self, info):
        self.receiver = waggle.EventReceiver(_placement(info), info.rectification)

    def push(self, input):
        self.receiver.set_ego_rotation(input.ego)
        step = self.receiver.push(
            input.events,
            input.start_ns,
            input.end_ns,
            input.seq,
            input.valid,
            input.continuous,
            input.width_px,
            input.height_px,
        )
        return FullStep(step.tokens, step.frames, step.point_px)

    def missing(self, stamp_ns):
        step = self.receiver.missing(stamp_ns)
        return FullStep(step.tokens, step.frames)

    def reset(self):
        self.receiver.reset()

    def counts(self):
        return self.receiver.counts()


class WaggleRgb:
    level = "full"

    def __init__(self, info):
        self.receiver = waggle.RgbReceiver(_placement(info), info.rectification)

    def push(self, input):
        self.receiver.set_ego_rotation(input.ego)
        step = self.receiver.push(
            input.frame, input.end_ns, input.seq, input.valid, input.continuous
        )
        return FullStep(step.tokens, step.frames, step.point_px)

    def missing(self, stamp_ns):
        step = self.receiver.missing(stamp_ns)
        return FullStep(step.tokens, step.frames)

    def reset(self):
        self.receiver.reset()
