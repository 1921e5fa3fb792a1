"""One trial's sensor inputs, with its ground truth, for offline work and for training receivers.

``waggle inputs`` (in the ``waggle`` binary) flies trial ``trial`` of a condition exactly as
``waggle trials`` does and streams every input each observer's receiver gets — event packets as
arrays of :data:`waggle.EVENT_DTYPE`, RGB frames as ``H×W×3 uint8`` — with the performer's
image position beside each, the broadcast's labelled timeline before them and the ideal
receiver's tokens after them. :func:`trial_inputs` runs it and reads the stream as it comes;
:func:`read_inputs` reads a stream saved with ``--out FILE``; :func:`export_labelled` writes
the inputs with per-event (or per-frame) labels to disk.
"""

from __future__ import annotations

import json
import os
import shutil
import struct
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Iterator, Optional, Sequence, Tuple

import numpy as np

from waggle.plugin import EVENT_DTYPE, ObserverInfo, SensorInput, input_fields

SYMBOLS = ("NULL", "START", "BIT0", "BIT1", "END", "UNKNOWN", "ACQUISITION")
"""Label codes: a label is an index into this tuple, −1 where no symbol is flown."""

MAX_FRAME_BYTES = 64 << 20
"""The largest frame the reader accepts (a 640×480 RGB frame is 0.9 MB)."""


class InputsError(ValueError):
    """A stream that is not what ``waggle inputs`` writes, or a run of it that failed."""


@dataclass(frozen=True)
class Span:
    """One labelled interval ``[start_ns, end_ns)`` of the broadcast."""

    symbol: str
    start_ns: int
    end_ns: int
    offer: Optional[int]
    payload: Optional[int]
    position: Optional[int]


@dataclass(frozen=True)
class Tick(SensorInput):
    """One input of one observer (a :class:`waggle.plugin.SensorInput`, as its receiver gets
    it), with the performer's position."""

    observer: str = ""
    performer_px: Optional[Tuple[float, float]] = None
    """The performer's centre projected into the image of the observer's latest render (its
    camera turned and moved as the airframe was: the label of the pixels this input shows);
    ``None`` when it is outside the image."""


def _frames(stream: IO[bytes]) -> Iterator[Tuple[dict, memoryview]]:
    while True:
        head = stream.read(4)
        if not head:
            return
        if len(head) < 4:
            raise InputsError("the stream ends inside a frame's length")
        (length,) = struct.unpack("<I", head)
        if length < 4 or length > MAX_FRAME_BYTES:
            raise InputsError(f"a frame claims {length} bytes (4…{MAX_FRAME_BYTES} allowed)")
        frame = stream.read(length)
        if len(frame) < length:
            raise InputsError("the stream ends inside a frame")
        (head_len,) = struct.unpack_from("<I", frame)
        if head_len > length - 4:
            raise InputsError("a frame's header is longer than the frame")
        try:
            header = json.loads(frame[4 : 4 + head_len])
        except ValueError as e:
            raise InputsError(f"a frame's header is not JSON: {e}") from None
        yield header, memoryview(frame)[4 + head_len :]


class TrialInputs:
    """A stream of one trial's inputs. Iterate it once for the :class:`Tick` objects; the
    header's fields are there before, :attr:`ideal` after."""

    def __init__(self, stream: IO[bytes], process: Optional[subprocess.Popen] = None):
        self._process = process
        self._stream = stream
        self._frames = _frames(stream)
        try:
            header, _ = next(self._frames)
        except StopIteration:
            raise InputsError(self._failure("the stream is empty")) from None
        if header.get("op") != "trial":
            raise InputsError(f"the stream starts with {header.get('op')!r}, not a trial")
        self.modality: str = header["modality"]
        self.trial: int = header["trial"]
        self.seed: int = header["seed"]
        self.perturb: dict = header["perturb"]
        self.observers = [ObserverInfo(**o) for o in header["observers"]]
        self.timeline = [Span(**s) for s in header["timeline"]]
        self.offers: list = header["offers"]
        self.ideal: Optional[dict] = None
        """Per observer, the ideal receiver's ``tokens`` (``(NAME, stamp_ns)``) and released
        ``frames`` (``(payload bits, stamp_ns)``): set once the stream has been read to its end."""

    def _failure(self, what: str) -> str:
        if self._process is None:
            return what
        err = self._process.stderr.read().decode(errors="replace") if self._process.stderr else ""
        self._process.wait()
        return f"{what}: waggle inputs exited {self._process.returncode}: {err.strip()}"

    def __iter__(self) -> Iterator[Tick]:
        for header, bulk in self._frames:
            op = header.get("op")
            if op == "end":
                self.ideal = header.get("ideal")
                self.close()
                return
            if op not in ("events", "rgb"):
                raise InputsError(f"unexpected frame {op!r}")
            try:
                fields = input_fields(header, bulk)
            except ValueError as e:
                raise InputsError(str(e)) from None
            px = header.get("performer_px")
            yield Tick(
                **fields,
                observer=header["observer"],
                performer_px=None if px is None else (float(px[0]), float(px[1])),
            )
        raise InputsError(self._failure("the stream ended before its end frame"))

    def close(self) -> None:
        """Stops reading (a running ``waggle inputs`` stops its flight)."""
        self._stream.close()
        if self._process is not None:
            self._process.wait()

    def __enter__(self) -> "TrialInputs":
        return self

    def __exit__(self, *_) -> None:
        self.close()

    def labels_at(self, t_ns: np.ndarray) -> np.ndarray:
        """The symbol flown at each time (an index into :data:`SYMBOLS`, −1 for none)."""
        starts = np.array([s.start_ns for s in self.timeline], dtype=np.int64)
        ends = np.array([s.end_ns for s in self.timeline], dtype=np.int64)
        codes = np.array([SYMBOLS.index(s.symbol) for s in self.timeline], dtype=np.int8)
        t = np.asarray(t_ns, dtype=np.int64)
        k = np.searchsorted(starts, t, side="right") - 1
        inside = (k >= 0) & (t < ends[np.clip(k, 0, None)])
        return np.where(inside, codes[np.clip(k, 0, None)], -1).astype(np.int8)


def read_inputs(path: os.PathLike | str) -> TrialInputs:
    """A stream saved by ``waggle inputs --out FILE``."""
    return TrialInputs(open(path, "rb"))


def _waggle_binary() -> str:
    found = os.environ.get("WAGGLE") or shutil.which("waggle")
    if not found:
        here = Path(__file__).resolve()
        for root in here.parents:
            candidate = root / "target" / "release" / "waggle"
            if candidate.is_file():
                return str(candidate)
        raise InputsError("no waggle binary: put it on PATH or name it in WAGGLE")
    return found


def trial_inputs(
    link: Sequence[str],
    modality: str,
    *,
    observers: int = 3,
    viewpoints: Sequence[Tuple[float, float, float]] = (),
    seed: int = 0,
    trial: int = 0,
    sensor_preset: Optional[str] = None,
    perturb: Sequence[str] = (),
    acquisition: Optional[bool] = None,
    rectify: Optional[str] = None,
    render: Optional[str] = None,
    real_noise: Optional[str] = None,
) -> TrialInputs:
    """Runs ``waggle inputs`` for trial ``trial`` of the condition ``waggle trials`` would run
    with the same arguments, and reads its stream as it comes (an RGB trial is gigabytes: it is
    never held whole). ``link`` holds six-bit payload strings (``"011010"``), ``perturb`` terms
    ``KEY=VALUE``, ``viewpoints`` ``(azimuth_deg, elevation_deg, distance_m)``. Bad arguments
    raise :class:`InputsError` with waggle's message."""
    if isinstance(link, str):
        raise InputsError("link: a list of six-bit payloads, e.g. ['011010']")
    args = [_waggle_binary(), "inputs", "--link", ",".join(link), "--modality", modality]
    args += ["--seed", str(int(seed)), "--trial", str(int(trial)), "--observers", str(int(observers))]
    for v in viewpoints:
        args.append("--viewpoint=" + ",".join(str(float(c)) for c in v))
    if sensor_preset is not None:
        args += ["--sensor-preset", sensor_preset]
    for term in perturb:
        args += ["--perturb", term]
    if acquisition is not None:
        args.append(f"--acquisition={'true' if acquisition else 'false'}")
    if rectify is not None:
        args += ["--rectify", rectify]
    if render is not None:
        args += ["--render", render]
    if real_noise is not None:
        args += ["--real-noise", real_noise]
    process = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    return TrialInputs(process.stdout, process)


def _npy_header(shape_tail: Tuple[int, ...], count: int) -> bytes:
    """A ``.npy`` (v1.0) header for ``count`` items of ``uint8`` arrays of ``shape_tail``, of a
    fixed length whatever ``count`` is, so it can be written first and rewritten last."""
    tail = "".join(f", {d}" for d in shape_tail)
    text = f"{{'descr': '|u1', 'fortran_order': False, 'shape': ({count:20d}{tail}), }}"
    pad = 64 - (10 + len(text) + 1) % 64
    text = text + " " * pad + "\n"
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(text)) + text.encode()


def export_labelled(inputs: TrialInputs, out_dir: os.PathLike | str) -> list:
    """Writes every observer's inputs with labels into ``out_dir`` and returns the files.

    Events: ``O1.npz`` with ``events`` (:data:`EVENT_DTYPE`), ``symbol`` (per event, an index
    into :data:`SYMBOLS` of what the performer flew at its time, −1 for nothing), per packet
    ``packet_end_ns`` and ``performer_px`` (NaN outside the image), and ``timeline``.
    RGB: ``O1-frames.npy`` (``N×H×W×3 uint8``, written as it streams) and ``O1.npz`` with
    per frame ``stamp_ns``, ``symbol`` and ``performer_px``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    per: dict = {}
    frames: dict = {}
    try:
        for tick in inputs:
            rec = per.setdefault(tick.observer, {"events": [], "stamp_ns": [], "px": []})
            rec["stamp_ns"].append(tick.end_ns)
            rec["px"].append(tick.performer_px or (np.nan, np.nan))
            if tick.kind == "events":
                rec["events"].append(np.array(tick.events))
            else:
                f = frames.get(tick.observer)
                if f is None:
                    f = frames[tick.observer] = [open(out / f"{tick.observer}-frames.npy", "wb"), 0, tick.frame.shape]
                    f[0].write(_npy_header(tick.frame.shape, 0))
                f[0].write(tick.frame.tobytes())
                f[1] += 1
    finally:
        for handle, count, shape in frames.values():
            handle.seek(0)
            handle.write(_npy_header(shape, count))
            handle.close()
    timeline = np.array(
        [(SYMBOLS.index(s.symbol), s.start_ns, s.end_ns) for s in inputs.timeline],
        dtype=[("symbol", "i1"), ("start_ns", "<i8"), ("end_ns", "<i8")],
    )
    written = []
    for name, rec in sorted(per.items()):
        stamps = np.array(rec["stamp_ns"], dtype=np.int64)
        arrays = {
            "performer_px": np.array(rec["px"], dtype=np.float64).reshape(-1, 2),
            "timeline": timeline,
        }
        if inputs.modality == "events":
            events = np.concatenate(rec["events"]) if rec["events"] else np.zeros(0, EVENT_DTYPE)
            arrays.update(events=events, symbol=inputs.labels_at(events["t_ns"]), packet_end_ns=stamps)
        else:
            arrays.update(stamp_ns=stamps, symbol=inputs.labels_at(stamps))
            written.append(out / f"{name}-frames.npy")
        np.savez_compressed(out / f"{name}.npz", **arrays)
        written.append(out / f"{name}.npz")
    return written
