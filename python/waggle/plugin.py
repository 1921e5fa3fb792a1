"""Receiver plug-ins: the three small protocols a Python receiver follows to be scored by
Waggle's instrument (``waggle trials --receiver python:MODULE:CLASS``), and what it is handed.

A plug-in is a class. Waggle makes one instance per observer and trial, ``CLASS(info)`` with an
:class:`ObserverInfo`, then calls ``push(input)`` with each :class:`SensorInput` of that
observer's own sensor, in time order. The class attribute ``level`` says what ``push`` returns
and so which part of Waggle's receiving chain the plug-in replaces:

``"tracker"`` (:class:`Tracker`)
    the target's image position for this input, ``(x_px, y_px)``, or ``None`` when it has no
    target. Waggle's segmenter, template matcher and frame parser do the rest, exactly as for
    its ideal baseline.
``"tokens"`` (:class:`TokenReceiver`)
    the motion tokens confirmed by this input, a list of ``(NAME, stamp_ns)`` with NAME one of
    ``NULL START BIT0 BIT1 END UNKNOWN``; Waggle's 17-token frame parser does the rest.
``"full"`` (:class:`FullReceiver`)
    a :class:`FullStep`: tokens as above and the frames released by this input, each
    ``(payload, token_stamps_ns)`` with the payload 0…63 (b1 most significant) and its 17
    token stamps; optionally the target's image position (``point_px``).

Optional methods: ``reset()`` (a new round or reception window: forget the target and any
partial frame), ``missing(stamp_ns)`` (the sensor stream is known to be missing; a token
or full receiver may return what it confirms then, as from ``push``) and ``counts()`` (asked
once the observer's inputs are done: a dict with any of ``events_received``,
``events_removed`` and ``events_removed_ego``, recorded with the trial as Waggle's event
receiver records its noise and ego-motion front ends').

Stamps are integer nanoseconds of simulated time; a token or frame may not be stamped after the
input that produced it, and stamps may not go back. A plug-in that raises, returns something
else, or runs past the trial's time limit fails that trial (recorded with the reason); the
study goes on. In a whole mission (``waggle run``/``mission --receiver O2=python:MODULE:CLASS``)
such a plug-in leaves its observer deaf for the rest of the mission, reported by name. Plug-ins run in a worker process of their own (``python -m waggle._worker``),
so printing is fine (it goes to standard error).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, NamedTuple, Optional, Protocol, Sequence, Tuple

import numpy as np

from waggle._native import EVENT_DTYPE

TOKEN_NAMES = ("NULL", "START", "BIT0", "BIT1", "END", "UNKNOWN")

Level = Literal["tracker", "tokens", "full"]


@dataclass(frozen=True)
class ObserverInfo:
    """The observer a plug-in instance serves: its camera and where it sits."""

    name: str
    """``O1``, ``O2``, …"""
    modality: str
    """``events`` or ``rgb``: which sensor's input ``push`` gets."""
    home_m: Tuple[float, float, float]
    yaw_rad: float
    pitch_rad: float
    """Camera pitch below the horizon."""
    rectification: str
    """The viewpoint rectification Waggle's own receivers use (``off``, ``pitched``, ``frontal``)."""
    width_px: int
    height_px: int
    focal_px: float
    principal_point_px: Tuple[float, float]
    seed: int
    """The trial's seed, for a plug-in that draws random numbers (keep trials reproducible)."""


@dataclass(frozen=True)
class SensorInput:
    """One message from the observer's own sensor: an event packet or an RGB frame."""

    kind: str
    """``events`` or ``rgb``."""
    seq: int
    start_ns: int
    """Events: the packet's start (exclusive). RGB: the frame's stamp."""
    end_ns: int
    """Events: the packet's end (inclusive). RGB: the frame's stamp."""
    width_px: int
    height_px: int
    valid: bool
    """False when the sensor marked this input as not to be trusted."""
    continuous: bool
    """False when this input does not directly follow the previous one."""
    events: Optional[np.ndarray]
    """Events: a read-only array of :data:`EVENT_DTYPE`, in time order. ``None`` for RGB."""
    frame: Optional[np.ndarray]
    """RGB: a read-only ``H×W×3`` ``uint8`` array. ``None`` for events."""
    ego: Optional[np.ndarray]
    """How far the airframe has turned from its home attitude (3×3 rotation, world axes), or
    ``None`` when it has not turned."""


def input_fields(header: dict, bulk: memoryview) -> dict:
    """The fields of a :class:`SensorInput` from a frame of the plug-in pipe (or of a
    ``waggle inputs`` stream): its header and its bulk, mapped by numpy without a copy. Raises
    ``ValueError`` when the bulk does not hold what the header says."""
    op = header["op"]
    if op == "events":
        if len(bulk) % EVENT_DTYPE.itemsize:
            raise ValueError("an event packet's bulk is not whole events")
        events, frame = np.frombuffer(bulk, dtype=EVENT_DTYPE), None
        start, end = header["start_ns"], header["end_ns"]
    elif op == "rgb":
        h, w = header["height"], header["width"]
        if len(bulk) != h * w * 3:
            raise ValueError(f"an RGB frame has {len(bulk)} bytes, not {h}×{w}×3")
        events, frame = None, np.frombuffer(bulk, dtype=np.uint8).reshape(h, w, 3)
        start = end = header["stamp_ns"]
    else:
        raise ValueError(f"{op!r} is not a sensor input")
    ego = header.get("ego")
    return dict(
        kind=op,
        seq=header["seq"],
        start_ns=start,
        end_ns=end,
        width_px=header["width"],
        height_px=header["height"],
        valid=header["valid"],
        continuous=header["continuous"],
        events=events,
        frame=frame,
        ego=None if ego is None else np.array(ego, dtype=np.float64),
    )


class FullStep(NamedTuple):
    """What a full receiver confirms on one input, and (optionally) where it placed the target:
    ``point_px`` is recorded as the observer's track in a whole mission, as Waggle's receivers'
    estimates are (``None``: no target, or not said)."""

    tokens: Sequence[Tuple[str, int]] = ()
    frames: Sequence[Tuple[int, Sequence[int]]] = ()
    point_px: Optional[Tuple[float, float]] = None


class Tracker(Protocol):
    level: Literal["tracker"]

    def __init__(self, info: ObserverInfo) -> None: ...

    def push(self, input: SensorInput) -> Optional[Tuple[float, float]]: ...


class TokenReceiver(Protocol):
    level: Literal["tokens"]

    def __init__(self, info: ObserverInfo) -> None: ...

    def push(self, input: SensorInput) -> Sequence[Tuple[str, int]]: ...


class FullReceiver(Protocol):
    level: Literal["full"]

    def __init__(self, info: ObserverInfo) -> None: ...

    def push(self, input: SensorInput) -> FullStep: ...
