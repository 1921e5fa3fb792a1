"""Reads a ROS 2 bag written by `waggle export ros2` with independent readers and prints a JSON
report for tests/tests/ros2_export.rs to compare with the recording:

- PyPI `rosbags` (its rosbag2 reader: metadata.yaml, MCAP storage, CDR deserializer) reads every
  message; standard types are checked against rosbags' own ROS 2 Jazzy type store (same fields,
  same RIHS01 type hash as the channel's `topic_type_hash`), other types (event_camera_msgs,
  waggle_msgs) are registered from the bag's `ros2msg` schemas and hashed the same way;
- `mcap-ros2-support` (the official MCAP Python reader's ROS 2 decoder) reads every message too,
  and both decodings must agree field for field;
- PyPI `evt3` decodes each camera's EventPacket payloads (`encoding: "evt3"`) as one stream in
  message order, and each packet alone (times modulo the 24-bit wrap); every event must fall in
  its packet's interval; the report gives count, last time and an order-sensitive checksum of
  (t_us, x, y, polarity), computed as tests/js/read_evt3.py does;
- PNG images are checked by signature, IHDR size and colour type;
- every waggle_msgs message is reported with its decoded values.

Usage: check_bag.py BAG_DIR  (run with the venv of deploy/setup.sh: tests/js/.venv/bin/python)
"""
import dataclasses
import json
import struct
import sys
from pathlib import Path

import evt3
import numpy as np
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore, get_types_from_msg

WRAP_US = 1 << 24
PACKET_NS = 40_000_000


def canon_rosbags(v):
    """A rosbags value as plain Python: messages as dicts, uint8 arrays as bytes."""
    if dataclasses.is_dataclass(v):
        return {f.name: canon_rosbags(getattr(v, f.name)) for f in dataclasses.fields(v)
                if not f.name.startswith("__") and not f.name.isupper()}  # no constants
    if isinstance(v, np.ndarray):
        return v.tobytes() if v.dtype == np.uint8 else tuple(v.tolist())
    if isinstance(v, (list, tuple)):
        return tuple(canon_rosbags(x) for x in v)
    if isinstance(v, np.generic):
        return v.item()
    return v


def canon_mcap(v):
    """An mcap_ros2 value as plain Python, like canon_rosbags."""
    slots = getattr(type(v), "__slots__", None)
    if slots is not None and not isinstance(v, (str, bytes, int, float, bool)):
        return {k: canon_mcap(getattr(v, k)) for k in slots}
    if isinstance(v, (list, tuple)):
        return tuple(canon_mcap(x) for x in v)
    return v


def checksum(t, x, y, p, start_index):
    """Order-sensitive checksum of events, as tests/js/read_evt3.py computes it."""
    i = np.arange(start_index + 1, start_index + len(t) + 1, dtype=np.uint64)
    with np.errstate(over="ignore"):
        v = (t.astype(np.uint64) * np.uint64(1_000_003) + x.astype(np.uint64) * np.uint64(1009)
             + y.astype(np.uint64) * np.uint64(17) + p.astype(np.uint64))
        return int((v * i).sum(dtype=np.uint64))


class EventStream:
    """One camera's EventPacket topic through the independent EVT 3.0 decoder."""

    def __init__(self, width, height):
        self.decoder = evt3.Decoder(sensor_width=width, sensor_height=height)
        self.size = (width, height)
        self.count = 0
        self.check = 0
        self.last_t_us = None
        self.packets = 0
        self.problems = []

    def feed(self, msg):
        self.packets += 1
        if msg.encoding != "evt3" or msg.is_bigendian or (msg.width, msg.height) != self.size:
            self.problems.append(f"packet {msg.seq}: {msg.encoding} {msg.width}x{msg.height}")
        data = bytes(msg.events)
        ev = self.decoder.feed(data)
        t, x, y, p = (np.asarray(a) for a in (ev.timestamp, ev.x, ev.y, ev.polarity))
        alone = evt3.decode_bytes(data, sensor_width=self.size[0], sensor_height=self.size[1])
        same = (len(alone.x) == len(x) and np.array_equal(alone.x, x) and np.array_equal(alone.y, y)
                and np.array_equal(alone.polarity, p)
                and np.array_equal(np.asarray(alone.timestamp) % WRAP_US, t % WRAP_US))
        if not same:
            self.problems.append(f"packet {msg.seq} decodes differently on its own")
        stamp_ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        if len(t) and (t.min() < stamp_ns // 1000 or t.max() > (stamp_ns + PACKET_NS) // 1000):
            self.problems.append(f"packet {msg.seq}: events outside its interval")
        self.check = (self.check + checksum(t, x, y, p, self.count)) % (1 << 64)
        self.count += len(t)
        if len(t):
            self.last_t_us = int(t[-1])

    def report(self):
        return {"packets": self.packets, "events": self.count, "checksum": self.check,
                "last_t_us": self.last_t_us, "problems": self.problems}


def png_size(data):
    """(width, height, colour type) from a PNG's IHDR, or None when it is not a PNG."""
    if data[:8] != b"\x89PNG\r\n\x1a\n" or data[12:16] != b"IHDR":
        return None
    width, height, _depth, colour = struct.unpack(">IIBB", data[16:26])
    return width, height, colour


def read_rosbags(bag):
    """Every message through rosbags, plus the type checks."""
    store = get_typestore(Stores.ROS2_JAZZY)
    jazzy = dict(store.fielddefs)
    types, messages, topic_types = {}, {}, {}
    with Reader(bag) as reader:
        meta = {"message_count": reader.message_count, "duration_ns": reader.duration,
                "topics": {c.topic: c.msgcount for c in reader.connections}}
        for c in reader.connections:
            topic_types[c.topic] = c.msgtype
            parsed = get_types_from_msg(c.msgdef.data, c.msgtype)
            same = all(jazzy[n] == f for n, f in parsed.items() if n in jazzy)
            new = {n: f for n, f in parsed.items() if n not in store.fielddefs}
            if new:
                store.register(new)
            types[c.msgtype] = {"standard": c.msgtype in jazzy, "fields_match_jazzy": same,
                                "hash_ok": store.hash_rihs01(c.msgtype) == c.digest,
                                "serialization": c.ext.serialization_format}
        for c, t, raw in reader.messages():
            messages.setdefault(c.topic, []).append(
                (t, canon_rosbags(store.deserialize_cdr(raw, c.msgtype))))
    return meta, types, messages, topic_types


def main():
    bag = Path(sys.argv[1])
    meta, types, by_rosbags, types_of = read_rosbags(bag)
    (mcap_file,) = bag.glob("*.mcap")
    streams, images, disagreements, per_topic = {}, {}, [], {}
    seen = {topic: 0 for topic in by_rosbags}
    with open(mcap_file, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        profile = reader.get_header().profile
        for schema, channel, message, msg in reader.iter_decoded_messages(log_time_order=False):
            topic = channel.topic
            per_topic[topic] = per_topic.get(topic, 0) + 1
            k = seen.get(topic, 0)
            seen[topic] = k + 1
            other = by_rosbags.get(topic, [])
            if k >= len(other) or other[k] != (message.log_time, canon_mcap(msg)):
                disagreements.append(f"{topic} #{k}")
            if schema.name == "event_camera_msgs/msg/EventPacket":
                if topic not in streams:
                    streams[topic] = EventStream(msg.width, msg.height)
                streams[topic].feed(msg)
            elif schema.name == "sensor_msgs/msg/CompressedImage":
                img = images.setdefault(topic, {"count": 0, "sizes": set(), "format": set()})
                img["count"] += 1
                img["sizes"].add(png_size(msg.data))
                img["format"].add(msg.format)
            elif schema.name == "sensor_msgs/msg/Image":
                img = images.setdefault(topic, {"count": 0, "sizes": set(), "format": set()})
                img["count"] += 1
                ok = len(msg.data) == msg.step * msg.height and msg.step == 3 * msg.width
                img["sizes"].add((msg.width, msg.height, msg.encoding if ok else "bad size"))
                img["format"].add(msg.encoding)
    # Every message of each waggle_msgs topic, as rosbags decoded it (for value checks; the
    # mcap_ros2 decoding is the same, or it is listed in disagreements).
    waggle = {t: [m for _, m in msgs] for t, msgs in by_rosbags.items()
              if types_of.get(t, "").startswith("waggle_msgs/")}
    for img in images.values():
        img["sizes"] = sorted(map(str, img["sizes"]))
        img["format"] = sorted(img["format"])
    print(json.dumps({
        "profile": profile,
        "metadata": meta,
        "types": types,
        "rosbags": {t: len(v) for t, v in by_rosbags.items()},
        "mcap_ros2": per_topic,
        "disagreements": disagreements[:20],
        "events": {t: s.report() for t, s in streams.items()},
        "images": images,
        "waggle": waggle,
    }, sort_keys=True, default=lambda b: {"bytes": len(b)}))


if __name__ == "__main__":
    main()
