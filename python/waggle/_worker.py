"""The worker process of a receiver plug-in: ``python -m waggle._worker MODULE:CLASS``.

Waggle starts one per job and talks to it over standard input and output in frames
(``u32 length | u32 header length | JSON header | bulk``, little-endian): ``hello`` checks the
plug-in's class loaded, ``open`` makes an
instance for an observer, ``events`` and ``rgb`` push one input (its data in the bulk, read by
numpy without a copy), ``reset``, ``missing`` and ``close``. Each gets one reply,
``{"ok": value}``, ``{"error": "…"}`` when the plug-in raised, or ``{"malformed": "…"}`` when
it returned something its level does not allow. The plug-in's own prints go to standard error.
"""

from __future__ import annotations

import importlib
import json
import math
import struct
import sys
import traceback

import numpy as np

from waggle.plugin import TOKEN_NAMES, ObserverInfo, SensorInput, input_fields

LEVELS = ("tracker", "tokens", "full")


class Malformed(Exception):
    """The plug-in returned what its level does not allow."""


def _read_exact(stream, n: int) -> bytes | None:
    data = stream.read(n)
    if data is None or len(data) < n:
        return None
    return data


def _stamp(v, what: str) -> int:
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
        raise Malformed(f"{what} is not an integer of nanoseconds: {v!r}")
    return int(v)


def _tokens(value, what: str = "push") -> list:
    if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        raise Malformed(f"{what} must return a list of (NAME, stamp_ns), not {value!r}")
    out = []
    for k, item in enumerate(value):
        try:
            name, stamp = item
        except (TypeError, ValueError):
            raise Malformed(f"token {k} is not (NAME, stamp_ns): {item!r}") from None
        if name not in TOKEN_NAMES:
            raise Malformed(f"token {k}: {name!r} is not one of {', '.join(TOKEN_NAMES)}")
        out.append([str(name), _stamp(stamp, f"token {k}'s stamp")])
    return out


def _frames(value) -> list:
    out = []
    for k, item in enumerate(value):
        try:
            payload, stamps = item
            stamps = [_stamp(s, f"a stamp of frame {k}") for s in stamps]
        except (TypeError, ValueError):
            raise Malformed(f"frame {k} is not (payload, [17 stamps]): {item!r}") from None
        out.append([_stamp(payload, f"frame {k}'s payload"), stamps])
    return out


def _point(value, what: str):
    """(x, y) as two finite floats, or None, sent as ``repr`` strings: Rust reads them back to the
    very same doubles (a JSON number's parse need not be exact to the last bit)."""
    if value is None:
        return None
    try:
        x, y = value
        point = [float(x), float(y)]
    except (TypeError, ValueError):
        raise Malformed(f"{what}, not {value!r}") from None
    if not all(math.isfinite(c) for c in point):
        raise Malformed(f"a point is not finite: {point}")
    return [repr(c) for c in point]


def _output(level: str, value):
    if level == "tracker":
        return {"point_px": _point(value, "a tracker returns (x_px, y_px) or None")}
    if level == "tokens":
        return {"tokens": _tokens([] if value is None else value)}
    if value is None:
        return {"tokens": [], "frames": []}
    tokens = value.get("tokens", ()) if isinstance(value, dict) else getattr(value, "tokens", None)
    frames = value.get("frames", ()) if isinstance(value, dict) else getattr(value, "frames", None)
    if tokens is None or frames is None:
        raise Malformed(f"a full receiver returns a FullStep(tokens, frames), not {value!r}")
    out = {"tokens": _tokens(tokens), "frames": _frames(frames)}
    point = value.get("point_px") if isinstance(value, dict) else getattr(value, "point_px", None)
    if point is not None:
        out["point_px"] = _point(point, "a full receiver's point_px is (x_px, y_px) or None")
    return out


COUNTS = ("events_received", "events_removed", "events_removed_ego")


def _counts(value) -> dict:
    if not isinstance(value, dict) or not set(value) <= set(COUNTS):
        raise Malformed(f"counts() returns a dict with keys among {', '.join(COUNTS)}, not {value!r}")
    return {k: None if v is None else _stamp(v, f"count {k}") for k, v in value.items()}


class Host:
    """The plug-in's class and its instances, one per observer."""

    def __init__(self, spec: str):
        self.spec = spec
        self.load_error = None
        self.cls = None
        module, _, name = spec.rpartition(":")
        try:
            self.cls = getattr(importlib.import_module(module), name)
        except Exception as e:  # reported on the first open, naming the plug-in
            self.load_error = f"could not load {spec}: {type(e).__name__}: {e}"
        self.instances: dict = {}

    def handle(self, header: dict, bulk: memoryview):
        op, observer = header.get("op"), header.get("observer")
        if op == "hello":
            if self.load_error:
                raise RuntimeError(self.load_error)
            return {"class": self.spec}
        if op == "open":
            if self.load_error:
                raise RuntimeError(self.load_error)
            instance = self.cls(ObserverInfo(**header["info"]))
            level = getattr(instance, "level", None)
            if level not in LEVELS:
                raise Malformed(f"{self.spec}'s level is {level!r}, not one of {', '.join(LEVELS)}")
            self.instances[observer] = (instance, level)
            return {"level": level}
        instance, level = self.instances[observer]
        if op in ("events", "rgb"):
            return _output(level, instance.push(SensorInput(**input_fields(header, bulk))))
        if op == "reset":
            if hasattr(instance, "reset"):
                instance.reset()
            return {}
        if op == "missing":
            value = instance.missing(header["stamp_ns"]) if hasattr(instance, "missing") else None
            return {} if level == "tracker" else _output(level, value)
        if op == "close":
            del self.instances[observer]
            return {"counts": _counts(instance.counts()) if hasattr(instance, "counts") else None}
        raise RuntimeError(f"unknown request {op!r}")


def _reply(out, message: dict) -> None:
    try:
        head = json.dumps(message, allow_nan=False).encode()
    except ValueError as e:
        head = json.dumps({"malformed": f"output is not finite JSON: {e}"}).encode()
    out.write(struct.pack("<II", len(head) + 4, len(head)) + head)
    out.flush()


def _where(e: BaseException) -> str:
    frames = traceback.extract_tb(e.__traceback__)
    return f" (at {frames[-1].filename}:{frames[-1].lineno})" if frames else ""


def main(argv: list) -> int:
    if len(argv) != 2 or ":" not in argv[1]:
        print("usage: python -m waggle._worker MODULE:CLASS", file=sys.stderr)
        return 2
    inp, out = sys.stdin.buffer, sys.stdout.buffer
    sys.stdout = sys.stderr  # a plug-in's print must never reach the pipe
    host = Host(argv[1])
    while True:
        head = _read_exact(inp, 4)
        if head is None:
            return 0
        (length,) = struct.unpack("<I", head)
        frame = _read_exact(inp, length)
        if frame is None or length < 4:
            return 1
        (head_len,) = struct.unpack_from("<I", frame)
        header = json.loads(frame[4 : 4 + head_len])
        bulk = memoryview(frame)[4 + head_len :]
        try:
            message = {"ok": host.handle(header, bulk)}
        except Malformed as e:
            message = {"malformed": str(e)}
        except Exception as e:
            message = {"error": f"{type(e).__name__}: {e}{_where(e)}"}
        _reply(out, message)


if __name__ == "__main__":
    sys.exit(main(sys.argv))
