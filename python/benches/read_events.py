"""How fast ``waggle.read_events`` reads a recorded link's event stream into numpy, against the
official ``mcap`` reader decoding the same packets with ``waggle.EventPacket``.

Records a one-observer session of ``--seconds`` of simulated time (default 97 s: a single offer
of site A on the air, cut at the time limit) with ``waggle run --record-events packets``, unless
``--recording`` names one, then reads one observer's events both ways in one process, checks the
arrays are equal and prints events per second, their ratio and the machine's state. Run from the
repository root with the package installed (``bash deploy/setup.sh``) and the binaries built::

    tests/js/.venv/bin/python python/benches/read_events.py [--sensor-preset v2e-noisy]
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from mcap.reader import make_reader

import waggle

ROOT = Path(__file__).resolve().parents[2]

CASE = """\
name = "link-{seconds}s"
observers = 1
offer_sites = ["A"]
rounds = 1
modalities = ["events"]
time_limit_s = {seconds}

[expected]
messages = [0]
work_units = 0
services = {{ O1 = [] }}
"""


def record(out, seconds, sensor_preset):
    """``out/run/session.mcap``: a one-observer events session of ``seconds`` of sim time."""
    case = out / "case.toml"
    case.write_text(CASE.format(seconds=seconds))
    binary = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target")) / "release" / "waggle"
    command = [str(binary), "run", str(case), "--modality", "events", "--record-events",
               "packets", "--quiet", "--out", str(out / "run")]
    if sensor_preset:
        command += ["--sensor-preset", sensor_preset]
    print("recording:", " ".join(command[1:]), flush=True)
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    return out / "run" / "session.mcap"


def with_mcap(path, observer):
    """The official reader, as a user would call it, and one ``EventPacket`` per message."""
    arrays = []
    with open(path, "rb") as f:
        reader = make_reader(f)
        topics = [f"/sensor/{observer}/events"]
        for _, _, message in reader.iter_messages(topics=topics, log_time_order=False):
            arrays.append(waggle.EventPacket.from_bytes(message.data).events())
    return np.concatenate(arrays)


def timed(read, repeats):
    """(seconds of each call, the last result)."""
    seconds, result = [], None
    for _ in range(repeats):
        result = None
        start = time.perf_counter()
        result = read()
        seconds.append(time.perf_counter() - start)
    return seconds, result


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--recording", type=Path, help="a session.mcap to read instead")
    parser.add_argument("--seconds", type=int, default=97, help="simulated time recorded")
    parser.add_argument("--sensor-preset", help="the event sensor's noise preset (default none)")
    parser.add_argument("--observer", default="O1")
    parser.add_argument("--repeats", type=int, default=7, help="calls of waggle.read_events")
    parser.add_argument("--mcap-repeats", type=int, default=3, help="passes of the mcap reader")
    args = parser.parse_args()

    with tempfile.TemporaryDirectory(prefix="waggle-read-events-") as tmp:
        path = args.recording or record(Path(tmp), args.seconds, args.sensor_preset)
        load_before = os.getloadavg()
        ours, events = timed(lambda: waggle.read_events(path, args.observer), args.repeats)
        theirs, expected = timed(lambda: with_mcap(path, args.observer), args.mcap_repeats)
        load_after = os.getloadavg()
        if not np.array_equal(events, expected):
            sys.exit("the two readers disagree")
        t_ns = events["t_ns"]
        print(f"file: {path} ({path.stat().st_size / 1e6:.1f} MB), observer {args.observer}: "
              f"{len(events)} events from {t_ns[0] / 1e9:.2f} s to {t_ns[-1] / 1e9:.2f} s")
        print(f"machine: {os.cpu_count()} CPUs, load average {load_before[0]:.2f} before, "
              f"{load_after[0]:.2f} after")
        rates = {}
        for name, seconds in (("waggle.read_events", ours), ("mcap + EventPacket", theirs)):
            best, median = min(seconds), statistics.median(seconds)
            rates[name] = len(events) / best
            print(f"{name:>20}: best {best:.4f} s, median {median:.4f} s of {len(seconds)}: "
                  f"{rates[name] / 1e6:.1f} M events/s (best), "
                  f"{len(events) / median / 1e6:.1f} M events/s (median)")
        print(f"ratio (best): {rates['waggle.read_events'] / rates['mcap + EventPacket']:.1f}x")


if __name__ == "__main__":
    main()
