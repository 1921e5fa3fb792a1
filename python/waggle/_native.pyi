"""Type stubs of ``waggle._native``, the compiled half of the ``waggle`` package (PyO3)."""

import os
from typing import Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

EVENT_DTYPE: np.dtype
"""One event, packed (13 bytes): ``t_ns`` ``<i8`` (ns of simulated time), ``x`` ``<u2`` (column),
``y`` ``<u2`` (row, top 0), ``polarity`` ``i1`` (+1 ON, −1 OFF)."""

_Placement = Tuple[float, float, float, float, float]
"""``(home_x_m, home_y_m, home_z_m, yaw_rad, pitch_rad)``: the observer's home (world metres),
its heading, and its camera's pitch below the horizon."""

_Rotation = Union[Sequence[Sequence[float]], npt.NDArray[np.floating]]
"""A row-major 3×3 rotation matrix in world axes taking the airframe's home attitude to its
current one (``proto::EgoRotation``); rows may be lists, tuples or a numpy array."""

class WaggleError(ValueError):
    """An argument Waggle cannot use; the message starts with the argument's name (for events,
    the first bad event's index and field)."""

class Step:
    """What one input (or one known gap) did to a receiver. Frozen; compares by value."""

    @property
    def tokens(self) -> list[Tuple[str, int]]:
        """Tokens confirmed, in order: ``(NAME, stamp_ns)`` with NAME one of ``NULL START BIT0
        BIT1 END UNKNOWN``."""
    @property
    def frames(self) -> list[Tuple[int, list[int]]]:
        """Frames released: ``(payload, token_stamps_ns)``, payload 0…63 (b1 most significant)
        and the stamps of its 17 tokens."""
    @property
    def point_px(self) -> Optional[Tuple[float, float]]:
        """Where the receiver placed the target for this input (image x right, y down), fed to
        the segmenter; ``None`` without a target."""
    @property
    def rejected(self) -> Optional[str]:
        """Why the receiver refused the input (``"reason: detail"``), ``None`` when it used it.
        A refused input interrupts tracking, as on an observer."""

class EventPacket:
    """One packet of events from one camera, as Waggle's receivers and its wire carry it.
    Frozen; compares by value."""

    def __init__(
        self,
        events: npt.NDArray[np.void],
        start_ns: int,
        end_ns: int,
        seq: int,
        valid: bool = True,
        continuous: bool = True,
        width: int = 640,
        height: int = 480,
    ) -> None:
        """The packet ``seq`` covering ``(start_ns, end_ns]`` (at most 2³²−1 ns) of a
        ``width``×``height`` sensor, holding ``events``: a 1-D C-contiguous array of
        :data:`EVENT_DTYPE` in time order, each event inside the interval and the sensor, with
        polarity ±1. Raises :class:`WaggleError` naming the first bad argument or event."""
    @staticmethod
    def from_bytes(data: bytes) -> EventPacket:
        """The packet a wire message (``proto::encode``) holds; :class:`WaggleError` naming
        ``data`` when it does not decode or is inconsistent."""
    def to_bytes(self) -> bytes:
        """The packet as a wire message (``proto::encode``: format version + bincode)."""
    def events(self) -> npt.NDArray[np.void]:
        """A new array of :data:`EVENT_DTYPE` holding the packet's events."""
    @property
    def seq(self) -> int:
        """Packet sequence number, contiguous from 0 for one camera."""
    @property
    def start_ns(self) -> int:
        """Start of the interval (exclusive), ns."""
    @property
    def end_ns(self) -> int:
        """End of the interval (inclusive), ns; the packet's stamp."""
    @property
    def width(self) -> int:
        """Sensor width, pixels."""
    @property
    def height(self) -> int:
        """Sensor height, pixels."""
    @property
    def valid(self) -> bool:
        """False when the sensor could not produce trustworthy data for this interval."""
    @property
    def continuous(self) -> bool:
        """False when this packet does not directly follow the previous one."""
    def __len__(self) -> int:
        """The number of events."""

class EventReceiver:
    """Waggle's event receiver as the paper configures it: 640×480 sensor; 40 ms packets, each
    covering exactly 40 ms and starting where the previous one ended (plus 40 ms per skipped
    sequence number); noise and ego-motion front ends, support tracker, acquisition gate, the
    shared segmenter and the 17-token frame parser."""

    def __init__(
        self, placement: Optional[_Placement] = None, rectification: str = "pitched"
    ) -> None:
        """The receiver of an observer placed at ``placement``, matching the trajectory
        rectified by ``rectification`` (``off``, ``pitched``, ``frontal``), exactly as an
        observer builds it (``Perception::for_camera``). Without a placement: the raw trajectory
        (``Perception::new``); ``frontal`` then raises :class:`WaggleError`."""
    def push(
        self,
        events: npt.NDArray[np.void],
        start_ns: int,
        end_ns: int,
        seq: int,
        valid: bool = True,
        continuous: bool = True,
        width: int = 640,
        height: int = 480,
    ) -> Step:
        """Feeds the next packet: ``events`` (an array of :data:`EVENT_DTYPE`, read without a
        copy) covering ``(start_ns, end_ns]``. Argument errors raise :class:`WaggleError`; a
        packet the receiver refuses (wrong size, watermarks, order) returns a :class:`Step`
        whose ``rejected`` says why."""
    def push_packet(self, packet: EventPacket) -> Step:
        """Feeds the next packet, already an :class:`EventPacket`."""
    def missing(self, stamp_ns: int) -> Step:
        """The packets are known to be missing at ``stamp_ns`` (publisher gone, a fault): drops
        the target and any incomplete frame (one ``UNKNOWN`` if a target was being tracked)."""
    def set_ego_rotation(self, rotation: Optional[_Rotation]) -> None:
        """How far the airframe has turned from its home attitude, undone on the target's track
        from the next packet on; ``None``: not turned. Raises :class:`WaggleError` for anything
        but a finite 3×3 rotation."""
    def set_frame_check(self, check: str) -> None:
        """The check the session's frames carry (``"none"``, the default, ``"parity"`` or
        ``"crc3"``), from the next packet on: a full-length frame is released only when its
        check agrees. Raises :class:`WaggleError` naming ``check`` for any other name."""
    def reset(self) -> None:
        """A new round or reception window: forgets target, partial frame and stream
        continuity."""
    def counts(self) -> dict[str, Optional[int]]:
        """What its front ends saw and removed so far, as a trial records them:
        ``events_received`` and ``events_removed`` (noise front end), ``events_removed_ego``
        (ego-motion front end; ``None`` while the airframe never turned)."""
    @property
    def placement(self) -> Optional[_Placement]:
        """The placement it was built with, or ``None``."""
    @property
    def rectification(self) -> str:
        """``off``, ``pitched`` or ``frontal``."""

class RgbReceiver:
    """Waggle's RGB receiver as the paper configures it: KLT target tracking on 25 Hz frames,
    the shared segmenter and 17-token frame parser."""

    def __init__(
        self, placement: Optional[_Placement] = None, rectification: str = "pitched"
    ) -> None:
        """As :class:`EventReceiver`'s, for the RGB chain."""
    def push(
        self,
        frame: npt.NDArray[np.uint8],
        stamp_ns: int,
        seq: int,
        valid: bool = True,
        continuous: bool = True,
    ) -> Step:
        """Feeds the next frame: ``H×W×3`` ``uint8``, C-contiguous, top row first, rendered at
        ``stamp_ns`` (at least 64×48). Anything else raises :class:`WaggleError` naming
        ``frame``; a frame the receiver refuses returns a :class:`Step` whose ``rejected`` says
        why."""
    def missing(self, stamp_ns: int) -> Step:
        """The frames are known to be missing at ``stamp_ns``: drops the target and any
        incomplete frame."""
    def set_ego_rotation(self, rotation: Optional[_Rotation]) -> None:
        """As :meth:`EventReceiver.set_ego_rotation`, from the next frame on."""
    def set_frame_check(self, check: str) -> None:
        """As :meth:`EventReceiver.set_frame_check`, from the next frame on."""
    def reset(self) -> None:
        """A new round or reception window: forgets target, partial frame and stream
        continuity."""
    @property
    def placement(self) -> Optional[_Placement]:
        """The placement it was built with, or ``None``."""
    @property
    def rectification(self) -> str:
        """``off``, ``pitched`` or ``frontal``."""

def read_events(
    path: Union[str, os.PathLike[str]], observer: Optional[str] = None, *, partial: bool = False
) -> npt.NDArray[np.void]:
    """The event packets of ``observer`` (``"O2"``; ``None``: every observer's) in the Waggle
    recording ``path`` (a ``session.mcap``), as one new array of :data:`EVENT_DTYPE`.

    Events come packet after packet in the order the recording holds them, each packet's in its
    own order: one observer's packets in the order its camera published them, and Waggle's
    cameras publish events in time order, so ``t_ns`` does not decrease; with ``observer=None``
    the observers' packets interleave as the recorder received them (sort by ``t_ns`` for one
    timeline). Empty packets add nothing.

    Raises ``OSError`` (``FileNotFoundError``, …) naming a file that cannot be read, and
    :class:`WaggleError` for a file that is not a recording, an observer it holds no packets of
    (naming those it does), a recording that keeps the cameras' input instead of their packets,
    or a packet that does not decode. A damaged or cut recording raises :class:`WaggleError`
    unless ``partial``: then the events of every intact chunk are returned (a gap where a chunk
    was lost) and a ``RuntimeWarning`` names the damage."""
