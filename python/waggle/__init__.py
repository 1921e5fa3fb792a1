"""Waggle's own motion-symbol receivers as Python objects.

:class:`EventReceiver` and :class:`RgbReceiver` are the very receivers a Waggle observer runs
(Rust, through PyO3), configured as the paper configures them: feed them an observer's own
event packets or RGB frames in time order and each input returns a :class:`Step` — the tokens it
confirmed as ``(NAME, stamp_ns)``, the frames it released as ``(payload, [17 token stamps])``
and where it placed the target in the image.

Events travel as numpy structured arrays of :data:`EVENT_DTYPE`, one record per event, packed
(13 bytes, no padding), little-endian:

============  ========  ==============================================================
field         dtype     meaning
============  ========  ==============================================================
``t_ns``      ``<i8``   time, integer nanoseconds of simulated time; a packet covering
                        ``(start_ns, end_ns]`` holds only events in that interval,
                        in time order
``x``         ``<u2``   pixel column, ``0 <= x < width`` (640)
``y``         ``<u2``   pixel row, ``0 <= y < height`` (480), top row 0
``polarity``  ``i1``    ``+1`` ON (brighter), ``-1`` OFF (darker)
============  ========  ==============================================================

Build one with ``np.zeros(n, dtype=waggle.EVENT_DTYPE)`` or
``np.frombuffer(data, dtype=waggle.EVENT_DTYPE)``; the receivers read it without copying.
An :class:`EventPacket` is one such packet as Waggle's wire carries it (``to_bytes`` /
``from_bytes``). Every bad argument raises :class:`WaggleError` (a ``ValueError``) naming it —
for events, the first bad event's index and field.

Two pure-Python modules go with them: :mod:`waggle.plugin`, the protocols a receiver of your
own follows to be scored by ``waggle trials --receiver python:MODULE:CLASS``, and
:mod:`waggle.inputs`, one trial's sensor inputs with their ground truth (``waggle inputs``),
for offline work and labelled training data.
"""

from waggle._native import (
    EVENT_DTYPE,
    EventPacket,
    EventReceiver,
    RgbReceiver,
    Step,
    WaggleError,
    read_events,
)
from waggle import inputs, plugin

__all__ = [
    "EVENT_DTYPE",
    "EventPacket",
    "EventReceiver",
    "RgbReceiver",
    "Step",
    "WaggleError",
    "inputs",
    "plugin",
    "read_events",
]
