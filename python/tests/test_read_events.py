"""``waggle.read_events`` against the official ``mcap`` reader: a recording of a short session
(two observers, event cameras, made here with ``waggle run``) read into one array equals the
packets the ``mcap`` package reads, decoded one by one with ``waggle.EventPacket``; a missing
file, an observer without packets and a cut file raise errors naming what is wrong.

Needs the ``waggle`` binaries (``cargo build --release --workspace --bins``; found as the Rust
tests find them: ``$CARGO_TARGET_DIR/release`` or ``target/release``) and the package installed
(``bash deploy/setup.sh``). Run from the repository root::

    tests/js/.venv/bin/python -m pytest python/tests
"""

import os
import shutil
import subprocess
import tempfile
import unittest
import warnings
from pathlib import Path

import numpy as np
from mcap.reader import NonSeekingReader

import waggle
from waggle import EVENT_DTYPE, EventPacket, WaggleError

ROOT = Path(__file__).resolve().parents[2]

# Two observers for 12 s of simulated time: the performer starts its broadcast at about 5 s, so
# both cameras see it move for several seconds (≈ 2 s of wall time).
CASE = """\
name = "read-events-test"
observers = 2
offer_sites = ["A"]
rounds = 1
modalities = ["events"]
time_limit_s = 12

[expected]
messages = [0, 0]
work_units = 0
services = { O1 = [], O2 = [] }
"""


def waggle_binary():
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    path = target / "release" / "waggle"
    if not path.is_file():
        raise RuntimeError(
            f"{path} is missing: build the binaries first: "
            "cargo build --release --workspace --bins"
        )
    return path


def mcap_events(path, topics):
    """The events of every packet on ``topics``, in file order, by the official reader."""
    arrays = []
    with open(path, "rb") as f:
        reader = NonSeekingReader(f, validate_crcs=True)
        for _, _, message in reader.iter_messages(topics=topics, log_time_order=False):
            arrays.append(EventPacket.from_bytes(message.data).events())
    return np.concatenate(arrays) if arrays else np.zeros(0, EVENT_DTYPE)


def chunk_records(data):
    """``(offset, body length)`` of each top-level chunk record of an intact MCAP file."""
    chunks, at = [], 8
    while at + 9 <= len(data) - 8:
        opcode, length = data[at], int.from_bytes(data[at + 1:at + 9], "little")
        if opcode == 0x06:
            chunks.append((at, length))
        at += 9 + length
    return chunks


class ReadEventsTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = Path(tempfile.mkdtemp(prefix="waggle-read-events-"))
        case = cls.dir / "case.toml"
        case.write_text(CASE)
        out = cls.dir / "run"
        run = subprocess.run(
            [str(waggle_binary()), "run", str(case), "--modality", "events", "--quiet",
             "--out", str(out)],
            capture_output=True, text=True, timeout=300,
        )
        if run.returncode != 0:
            shutil.rmtree(cls.dir, ignore_errors=True)
            raise RuntimeError(f"waggle run failed:\n{run.stdout}\n{run.stderr}")
        cls.recording = out / "session.mcap"

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.dir, ignore_errors=True)

    def test_one_observer_equals_the_official_reader_packet_by_packet(self):
        for observer in ("O1", "O2"):
            got = waggle.read_events(self.recording, observer)
            want = mcap_events(self.recording, [f"/sensor/{observer}/events"])
            self.assertEqual(got.dtype, EVENT_DTYPE)
            self.assertGreater(len(got), 10_000, observer)
            np.testing.assert_array_equal(got, want)
            # One camera's packets follow each other: its events never go back in time.
            self.assertTrue(np.all(np.diff(got["t_ns"]) >= 0), observer)
            self.assertTrue(set(np.unique(got["polarity"])) <= {-1, 1})

    def test_every_observer_comes_in_file_order(self):
        got = waggle.read_events(str(self.recording))
        want = mcap_events(self.recording, ["/sensor/O1/events", "/sensor/O2/events"])
        np.testing.assert_array_equal(got, want)
        both = len(waggle.read_events(self.recording, "O1")) + len(
            waggle.read_events(self.recording, "O2"))
        self.assertEqual(len(got), both)

    def test_the_array_is_writable_and_owns_its_records(self):
        events = waggle.read_events(self.recording, "O1")
        self.assertTrue(events.flags["C_CONTIGUOUS"] and events.flags["WRITEABLE"])
        again = waggle.read_events(self.recording, "O1")
        events["x"] = 0
        self.assertGreater(int(again["x"].max()), 0)

    def test_a_missing_file_is_a_file_not_found_error_naming_it(self):
        missing = self.dir / "nope.mcap"
        with self.assertRaises(FileNotFoundError) as caught:
            waggle.read_events(missing, "O1")
        self.assertEqual(caught.exception.filename, str(missing))

    def test_a_file_that_is_not_a_recording_names_the_path(self):
        other = self.dir / "case.toml"
        with self.assertRaises(WaggleError) as caught:
            waggle.read_events(other)
        self.assertIn(str(other), str(caught.exception))
        self.assertIn("not an MCAP file", str(caught.exception))

    def test_an_observer_without_packets_is_named_with_those_the_file_has(self):
        with self.assertRaises(WaggleError) as caught:
            waggle.read_events(self.recording, "O7")
        message = str(caught.exception)
        self.assertTrue(message.startswith("observer:"), message)
        self.assertIn("O7", message)
        self.assertIn("O1, O2", message)
        with self.assertRaises(WaggleError) as caught:
            waggle.read_events(self.recording, "O/1")
        self.assertTrue(str(caught.exception).startswith("observer:"))

    def test_a_cut_file_is_an_error_unless_a_partial_read_is_asked_for(self):
        whole = self.recording.read_bytes()
        cut = self.dir / "cut.mcap"
        cut.write_bytes(whole[: len(whole) * 2 // 3])
        with self.assertRaises(WaggleError) as caught:
            waggle.read_events(cut, "O1")
        message = str(caught.exception)
        self.assertIn(str(cut), message)
        self.assertIn("cut short", message)
        self.assertIn("partial=True", message)
        with warnings.catch_warnings(record=True) as caught_warnings:
            warnings.simplefilter("always")
            part = waggle.read_events(cut, "O1", partial=True)
        self.assertEqual(len(caught_warnings), 1)
        self.assertIs(caught_warnings[0].category, RuntimeWarning)
        self.assertIn("read partially", str(caught_warnings[0].message))
        # What was read is the start of the whole stream, nothing else.
        full = waggle.read_events(self.recording, "O1")
        self.assertGreater(len(part), 0)
        self.assertLess(len(part), len(full))
        np.testing.assert_array_equal(part, full[: len(part)])

    def test_a_damaged_chunk_is_skipped_in_a_partial_read(self):
        whole = bytearray(self.recording.read_bytes())
        chunks = chunk_records(whole)
        self.assertGreater(len(chunks), 3)
        start, length = chunks[len(chunks) // 2]
        middle = start + 9 + length // 2
        whole[middle:middle + 64] = bytes(b ^ 0x5A for b in whole[middle:middle + 64])
        damaged = self.dir / "damaged.mcap"
        damaged.write_bytes(bytes(whole))
        with self.assertRaises(WaggleError) as caught:
            waggle.read_events(damaged, "O1")
        self.assertIn("damaged", str(caught.exception))
        with warnings.catch_warnings(record=True):
            warnings.simplefilter("always")
            part = waggle.read_events(damaged, "O1", partial=True)
        full = waggle.read_events(self.recording, "O1")
        self.assertLess(len(part), len(full))
        # Whole packets are lost, in one stretch; the rest is as recorded.
        differ = np.flatnonzero(part != full[: len(part)])
        head = differ[0] if len(differ) else len(part)
        np.testing.assert_array_equal(part[:head], full[:head])
        np.testing.assert_array_equal(part[head:], full[len(full) - (len(part) - head):])


if __name__ == "__main__":
    unittest.main()
