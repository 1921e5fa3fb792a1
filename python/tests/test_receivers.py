"""The ``waggle`` Python package against its contract: event arrays and packets round-trip, bad
arguments raise ``WaggleError`` (a ``ValueError``) naming the argument, and Waggle's own event
and RGB receivers, fed synthetic scenes, track the target where it is.

Run with the package installed (``bash deploy/setup.sh`` builds it into tests/js/.venv), from the
repository root so that the source folder ``python/waggle`` (without the compiled part) does not
shadow it::

    tests/js/.venv/bin/python -m pytest python/tests
"""

import math
import unittest

import numpy as np

import waggle
from waggle import EVENT_DTYPE, EventPacket, EventReceiver, RgbReceiver, Step, WaggleError

PERIOD_NS = 40_000_000
WIDTH, HEIGHT = 640, 480


def events(rows):
    """An EVENT_DTYPE array from ``(t_ns, x, y, polarity)`` rows."""
    return np.array(rows, dtype=EVENT_DTYPE)


def swing_x(t_ns):
    """The target's image column: a 2 s swing of ±70 px about the centre."""
    return 320 + 70 * math.sin(2 * math.pi * t_ns / 1e9 / 2.0)


def bar_events(duration_s, size=(48, 12), centre_y=240):
    """Edge events of a dark bar swinging left and right along ``swing_x`` (1 ms steps): OFF
    where it arrives, ON where it leaves, in time order."""
    step_ns = 1_000_000
    rows = np.arange(centre_y - size[1] // 2, centre_y + size[1] // 2)
    out = []
    left = math.floor(swing_x(0) - size[0] / 2)
    for t in range(step_ns, int(duration_s * 1e9) + 1, step_ns):
        now = math.floor(swing_x(t) - size[0] / 2)
        if now > left:
            arrive, leave = range(left + size[0], now + size[0]), range(left, now)
        else:
            arrive, leave = range(now, left), range(now + size[0], left + size[0])
        for cols, p in ((arrive, -1), (leave, 1)):
            out.extend((t, c, y, p) for c in cols for y in rows)
        left = now
    return events(out)


def packets(stream, count):
    """``(events, start_ns, end_ns, seq)`` of the first ``count`` 40 ms packets of ``stream``."""
    for k in range(count):
        start, end = k * PERIOD_NS, (k + 1) * PERIOD_NS
        chosen = stream[(stream["t_ns"] > start) & (stream["t_ns"] <= end)]
        yield chosen, start, end, k


# The RGB receiver's test drone (libs/perception/tests/support/rgb_scene.rs): disjoint
# rectangles `[x0, x1, y0, y1, grey]` about its centre, on a blue-grey wall.
DRONE = [
    [-24, -14, -6, -4.5, 235], [14, 24, -6, -4.5, 235], [-21, -17, -4.5, 2, 25],
    [17, 21, -4.5, 2, 25], [-17, -6, -1, 1, 40], [6, 17, -1, 1, 40], [-6, 6, -3, 1, 200],
    [-4, 4, 1, 4, 30], [-20, -18, 2, 6, 240], [18, 20, 2, 6, 240],
]


def drone_frame(x, y=240):
    frame = np.empty((HEIGHT, WIDTH, 3), np.uint8)
    frame[:] = (110, 128, 150)
    for x0, x1, y0, y1, grey in DRONE:
        frame[round(y + y0):round(y + y1), round(x + x0):round(x + x1)] = grey
    return frame


def assert_step(test, step):
    test.assertIsInstance(step, Step)
    test.assertIsInstance(step.tokens, list)
    for name, stamp in step.tokens:
        test.assertIn(name, ("NULL", "START", "BIT0", "BIT1", "END", "UNKNOWN"))
        test.assertIsInstance(stamp, int)
    test.assertIsInstance(step.frames, list)
    for payload, stamps in step.frames:
        test.assertTrue(0 <= payload < 64)
        test.assertEqual(len(stamps), 17)
    if step.point_px is not None:
        test.assertEqual(len(step.point_px), 2)
        test.assertTrue(all(isinstance(c, float) for c in step.point_px))
    test.assertTrue(step.rejected is None or isinstance(step.rejected, str))


class EventDtypeTest(unittest.TestCase):
    def test_the_dtype_is_packed_little_endian_records(self):
        self.assertEqual(
            EVENT_DTYPE,
            np.dtype([("t_ns", "<i8"), ("x", "<u2"), ("y", "<u2"), ("polarity", "i1")]),
        )
        self.assertEqual(EVENT_DTYPE.itemsize, 13)
        self.assertEqual([EVENT_DTYPE.fields[f][1] for f in EVENT_DTYPE.names], [0, 8, 10, 12])
        self.assertIs(waggle.EVENT_DTYPE, waggle._native.EVENT_DTYPE)

    def test_waggle_error_is_a_value_error(self):
        self.assertTrue(issubclass(WaggleError, ValueError))


class EventPacketTest(unittest.TestCase):
    def sample(self, n=500, seed=7):
        rng = np.random.default_rng(seed)
        e = np.zeros(n, dtype=EVENT_DTYPE)
        e["t_ns"] = np.sort(rng.integers(1_000_001, 1_000_000 + PERIOD_NS + 1, n))
        e["x"] = rng.integers(0, WIDTH, n)
        e["y"] = rng.integers(0, HEIGHT, n)
        e["polarity"] = rng.choice([-1, 1], n)
        return e

    def test_an_array_round_trips_through_a_packet_and_its_wire_bytes(self):
        e = self.sample()
        packet = EventPacket(e, 1_000_000, 1_000_000 + PERIOD_NS, 9, valid=False, continuous=False)
        self.assertEqual(len(packet), len(e))
        self.assertEqual(
            (packet.seq, packet.start_ns, packet.end_ns, packet.width, packet.height),
            (9, 1_000_000, 1_000_000 + PERIOD_NS, WIDTH, HEIGHT),
        )
        self.assertFalse(packet.valid)
        self.assertFalse(packet.continuous)
        out = packet.events()
        self.assertEqual(out.dtype, EVENT_DTYPE)
        np.testing.assert_array_equal(out, e)
        again = EventPacket.from_bytes(packet.to_bytes())
        self.assertEqual(again, packet)
        np.testing.assert_array_equal(again.events(), e)

    def test_read_only_and_empty_arrays_are_accepted(self):
        e = self.sample(40)
        frozen = np.frombuffer(e.tobytes(), dtype=EVENT_DTYPE)
        self.assertFalse(frozen.flags.writeable)
        np.testing.assert_array_equal(EventPacket(frozen, 1_000_000, 41_000_000, 0).events(), e)
        empty = EventPacket(np.zeros(0, EVENT_DTYPE), 0, PERIOD_NS, 0)
        self.assertEqual(len(empty), 0)
        self.assertEqual(empty.events().shape, (0,))

    def test_the_first_bad_event_is_named_with_its_field(self):
        good = (1_000, 10, 10, 1)
        cases = {
            "t_ns": [(0, 10, 10, 1), (PERIOD_NS + 1, 10, 10, 1), (-3, 10, 10, 1), (999, 1, 1, 1)],
            "x": [(2_000, WIDTH, 10, 1)],
            "y": [(2_000, 10, HEIGHT, 1)],
            "polarity": [(2_000, 10, 10, 0), (2_000, 10, 10, 2)],
        }
        for field, bad_rows in cases.items():
            for bad in bad_rows:
                with self.subTest(field=field, bad=bad):
                    with self.assertRaises(WaggleError) as caught:
                        EventPacket(events([good, bad, good]), 0, PERIOD_NS, 0)
                    self.assertIn("event 1", str(caught.exception))
                    self.assertIn(f"field {field}", str(caught.exception))
                    self.assertIsInstance(caught.exception, ValueError)

    def test_an_unusable_array_names_events(self):
        e = self.sample(10)
        aligned = np.dtype(
            [("t_ns", "<i8"), ("x", "<u2"), ("y", "<u2"), ("polarity", "i1")], align=True
        )
        swapped = np.dtype([("t_ns", ">i8"), ("x", "<u2"), ("y", "<u2"), ("polarity", "i1")])
        renamed = np.dtype([("t", "<i8"), ("x", "<u2"), ("y", "<u2"), ("polarity", "i1")])
        unusable = [
            e.astype(aligned),
            e.astype(swapped),
            e.view(renamed),
            np.zeros(10, np.int64),
            e.reshape(2, 5),
            e[::2],
            [tuple(r) for r in e],
        ]
        for value in unusable:
            with self.subTest(value=getattr(value, "dtype", type(value))):
                with self.assertRaisesRegex(WaggleError, r"^events: "):
                    EventPacket(value, 1_000_000, 41_000_000, 0)

    def test_bad_header_arguments_are_named(self):
        e = events([])
        cases = [
            ("start_ns", dict(start_ns=-1, end_ns=PERIOD_NS, seq=0)),
            ("end_ns", dict(start_ns=PERIOD_NS, end_ns=0, seq=0)),
            ("end_ns", dict(start_ns=0, end_ns=2**32, seq=0)),
            ("seq", dict(start_ns=0, end_ns=PERIOD_NS, seq=-1)),
            ("seq", dict(start_ns=0, end_ns=PERIOD_NS, seq=2**64)),
            ("width", dict(start_ns=0, end_ns=PERIOD_NS, seq=0, width=70_000)),
            ("height", dict(start_ns=0, end_ns=PERIOD_NS, seq=0, height=-480)),
        ]
        for arg, kwargs in cases:
            with self.subTest(arg=arg, kwargs=kwargs):
                with self.assertRaisesRegex(WaggleError, f"^{arg}: "):
                    EventPacket(e, **kwargs)

    def test_undecodable_bytes_name_data(self):
        good = EventPacket(events([(5, 1, 1, 1)]), 0, PERIOD_NS, 0).to_bytes()
        for data in (b"", good[:-1], good + b"\0"):
            with self.subTest(size=len(data)):
                with self.assertRaisesRegex(WaggleError, r"^data: "):
                    EventPacket.from_bytes(data)


class EventReceiverTest(unittest.TestCase):
    STREAM = bar_events(3.0)

    def test_it_tracks_a_swinging_bar_where_it_is(self):
        receiver = EventReceiver()
        located = 0
        for chosen, start, end, seq in packets(self.STREAM, 75):
            step = receiver.push(chosen, start, end, seq)
            assert_step(self, step)
            self.assertIsNone(step.rejected)
            if step.point_px is None or seq < 10:
                continue
            located += 1
            x, y = step.point_px
            # The support tracker smooths: it trails a 220 px/s target by about 10 px.
            self.assertLess(abs(x - swing_x(end)), 20, f"packet {seq}")
            self.assertLess(abs(y - 240), 3, f"packet {seq}")
        self.assertGreater(located, 60)
        missing = receiver.missing(75 * PERIOD_NS)
        assert_step(self, missing)
        self.assertEqual(missing.tokens, [("UNKNOWN", 75 * PERIOD_NS)])
        self.assertIsNone(missing.point_px)

    def test_arrays_packets_and_wire_bytes_give_the_same_steps(self):
        by_array, by_packet, by_bytes = EventReceiver(), EventReceiver(), EventReceiver()
        for chosen, start, end, seq in packets(self.STREAM, 40):
            packet = EventPacket(chosen, start, end, seq)
            a = by_array.push(chosen, start, end, seq)
            b = by_packet.push_packet(packet)
            c = by_bytes.push_packet(EventPacket.from_bytes(packet.to_bytes()))
            self.assertEqual(a, b)
            self.assertEqual(a, c)

    def test_a_placement_and_rectification_build_an_observers_receiver(self):
        placement = (0.0, -1.3, 1.0, math.pi / 2, 0.2)
        for mode in ("off", "pitched", "frontal"):
            receiver = EventReceiver(placement, rectification=mode)
            self.assertEqual(receiver.placement, placement)
            self.assertEqual(receiver.rectification, mode)
            chosen, start, end, seq = next(packets(self.STREAM, 1))
            assert_step(self, receiver.push(chosen, start, end, seq))
        self.assertIsNone(EventReceiver(None, "off").placement)

    def test_refused_packets_say_why(self):
        receiver = EventReceiver()
        chosen, start, end, seq = next(packets(self.STREAM, 1))
        step = receiver.push(events([]), start, end, seq, width=320)
        self.assertTrue(step.rejected.startswith("dimensions"), step.rejected)
        step = receiver.push(events([]), 0, PERIOD_NS // 2, 0)
        self.assertTrue(step.rejected.startswith("watermarks"), step.rejected)
        self.assertIsNone(receiver.push(chosen, start, end, seq).rejected)

    def test_ego_rotation_and_reset(self):
        receiver = EventReceiver()
        turn = 0.01
        c, s = math.cos(turn), math.sin(turn)
        receiver.set_ego_rotation([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        receiver.set_ego_rotation(np.eye(3))
        receiver.set_ego_rotation(None)
        for bad in ([[1, 0], [0, 1]], np.eye(3) * 2, -np.eye(3), [[math.nan] * 3] * 3, "eye"):
            with self.subTest(bad=bad):
                with self.assertRaisesRegex(WaggleError, r"^rotation: "):
                    receiver.set_ego_rotation(bad)
        for chosen, start, end, seq in packets(self.STREAM, 5):
            receiver.push(chosen, start, end, seq)
        self.assertIsNone(receiver.reset())
        # After a reset the stream starts afresh: an earlier sequence number is no restart.
        chosen, start, end, seq = next(packets(self.STREAM, 1))
        self.assertIsNone(receiver.push(chosen, start, end, seq).rejected)

    def test_a_frame_check_is_set_by_name_and_a_wrong_name_is_refused(self):
        for receiver in (EventReceiver(), RgbReceiver()):
            for name in ("none", "parity", "crc3"):
                self.assertIsNone(receiver.set_frame_check(name))
            for bad in ("CRC3", "crc", ""):
                with self.subTest(receiver=type(receiver).__name__, bad=bad):
                    with self.assertRaisesRegex(WaggleError, r"^check: frame_check = "):
                        receiver.set_frame_check(bad)

    def test_bad_construction_and_push_arguments_are_named(self):
        cases = [
            ("rectification", lambda: EventReceiver(rectification="sideways")),
            ("rectification", lambda: EventReceiver(None, "frontal")),
            ("placement", lambda: EventReceiver((0.0, 1.0, 2.0))),
            ("placement", lambda: EventReceiver((0.0, 1.0, 2.0, math.nan, 0.0))),
            ("placement", lambda: EventReceiver("O1")),
            ("stamp_ns", lambda: EventReceiver().missing(-1)),
            ("start_ns", lambda: EventReceiver().push(events([]), -PERIOD_NS, 0, 0)),
            ("events", lambda: EventReceiver().push(np.zeros(3), 0, PERIOD_NS, 0)),
        ]
        for arg, call in cases:
            with self.subTest(arg=arg):
                with self.assertRaisesRegex(WaggleError, f"^{arg}: "):
                    call()


class RgbReceiverTest(unittest.TestCase):
    def test_it_tracks_a_swinging_drone_where_it_is(self):
        receiver = RgbReceiver()
        located = 0
        for seq in range(40):
            stamp = (seq + 1) * PERIOD_NS
            step = receiver.push(drone_frame(swing_x(stamp)), stamp, seq)
            assert_step(self, step)
            self.assertIsNone(step.rejected)
            if step.point_px is not None:
                located += 1
                self.assertLess(abs(step.point_px[0] - swing_x(stamp)), 4, f"frame {seq}")
                self.assertLess(abs(step.point_px[1] - 240), 4, f"frame {seq}")
        self.assertGreater(located, 30)
        assert_step(self, receiver.missing(41 * PERIOD_NS))
        receiver.reset()

    def test_refused_frames_say_why(self):
        receiver = RgbReceiver()
        step = receiver.push(np.zeros((32, 32, 3), np.uint8), PERIOD_NS, 0)
        self.assertTrue(step.rejected.startswith("too-small"), step.rejected)
        receiver.push(drone_frame(320), 2 * PERIOD_NS, 1)
        step = receiver.push(drone_frame(320), 2 * PERIOD_NS, 2)
        self.assertTrue(step.rejected.startswith("stamp-not-increasing"), step.rejected)

    def test_unusable_frames_name_frame(self):
        frame = drone_frame(320)
        unusable = [
            frame.astype(np.float32),
            frame[:, :, 0],
            np.zeros((HEIGHT, WIDTH, 4), np.uint8),
            frame[:, ::2],
            np.asfortranarray(frame),
            frame.tolist(),
        ]
        receiver = RgbReceiver()
        for k, value in enumerate(unusable):
            with self.subTest(k=k):
                with self.assertRaisesRegex(WaggleError, r"^frame: "):
                    receiver.push(value, PERIOD_NS, 0)
        with self.assertRaisesRegex(WaggleError, r"^stamp_ns: "):
            receiver.push(frame, -1, 0)
        with self.assertRaisesRegex(WaggleError, r"^seq: "):
            receiver.push(frame, PERIOD_NS, -1)


if __name__ == "__main__":
    unittest.main()
