"""A ROS 2 camera driver for `waggle observe`, written with independent code: Eclipse Zenoh's own
Python client publishes `event_camera_msgs/msg/EventPacket` messages (or a bag's
`sensor_msgs/msg/Image` or `CompressedImage` messages) as a node on ROS 2 Jazzy's `rmw_zenoh`
middleware would, PyPI `rosbags` serializes and decodes them, and PyPI `evt3` counts the events
they carry.

  publish_events.py publish ENDPOINT DOMAIN TOPIC SOURCE OUT_JSON [--chunk-bytes N] [--listen-s S]
                    [--junk] [--bag-topic BAG_TOPIC]
      A Zenoh peer listening on ENDPOINT (`tcp/127.0.0.1:PORT`; the observer connects to it as
      to `rmw_zenohd`), multicast scouting off. Prints "ready" once subscribed to every sample on
      `DOMAIN/**` and to the liveliness tokens on `@ros2_lv/DOMAIN/**` (history included), then:
      - waits (at most 30 s) for a subscription token (`MS`) of TOPIC (e.g. `/camera/events`,
        mangled `%camera%events`; matched by topic name alone): the observer's;
      - declares its own tokens as rmw_zenoh does: node `event_camera_driver` (`NN`) and its
        publisher of TOPIC (`MP`, of the forwarded type: `event_camera_msgs::msg::dds_::
        EventPacket_`, or with --bag-topic `sensor_msgs::msg::dds_::Image_` or `sensor_msgs::
        msg::dds_::CompressedImage_`; the RIHS01 hash rosbags computes for it; volatile QoS);
      - publishes every message of SOURCE on `DOMAIN/<topic>/<that type>/RIHS01_<hash>` (e.g.
        `0/camera/events/event_camera_msgs::msg::dds_::EventPacket_/RIHS01_…`), reliable,
        congestion control BLOCK, each with the rmw_zenoh attachment (int64 sequence number from
        1, int64 source timestamp = wall clock ns, the publisher's 16-byte GID) serialized with
        `zenoh.ext.z_serialize`; with --junk, three malformed messages follow the first one:
        its CDR cut to 10 bytes; its copy with `encoding` "mono" (Image: "yuv422";
        CompressedImage: `format` "jpeg"); and one of half the width and height (e.g. 320x240
        after 640x480), valid otherwise: an EventPacket with no events, an Image of every other
        pixel of every other row, a CompressedImage holding a PNG (same bit depth and colour
        type, all samples 0);
      - waits for the observer's samples to stop (1.5 s with nothing new, at most --listen-s,
        default 10 s, after the last message), withdraws its MP and NN tokens (the observer ends
        when every publisher of its topic is gone) and keeps listening until the observer's
        session has withdrawn all its tokens (it publishes its last outputs after dropping its
        subscription) and 0.3 s more without a sample, at most max(2 s, --listen-s);
      - writes OUT_JSON: {"messages" (the source's, junk not counted), "junk" (0 or 3), "bytes"
        (event payload bytes; for images the bytes of their `data`), "events" (CD events in
        what was published; 0 for images), "images" (only for an Image or CompressedImage
        source: its messages forwarded, junk not counted), "received": {KEY: {"count",
        "decoded", "errors", "types" (the ROS type), "tokens_kinds" (kinds of the tokens seen
        naming that topic and type), "seqs_ok", "one_gid", "stamps_ok"}}, "frames" and "tokens"
        (every waggle_msgs/msg/Frame and waggle_msgs/msg/Token received, all fields, in arrival
        order), "received_tokens" ([{"key", "kind", "state": "put"|"delete", "ours"}] in
        arrival order), and details ("source", "counter", "type_hash", "publish_key",
        "nn_token", "mp_token", "ms_tokens", "matched" (a subscriber matched the publisher
        before the first message), "publish_s", "observer_left")}.

  publish_events.py count SOURCE [--chunk-bytes N] [--bag-topic BAG_TOPIC]
      Prints {"messages": N, "events": E} for SOURCE (and "images": N for an Image or
      CompressedImage source, whose "events" is 0), split and counted as `publish` does,
      without any networking.

SOURCE is either
  - a ROS 2 bag (a directory with metadata.yaml, or its `.mcap` file), e.g. written by `waggle
    export ros2`: the raw CDR payloads of one topic are forwarded unchanged, in the bag's order.
    Without --bag-topic that topic is `/O1/events` (or the bag's only EventPacket topic), its
    messages in the order rosbags reads them, each little-endian evt3. With --bag-topic it is
    BAG_TOPIC, of type `event_camera_msgs/msg/EventPacket` (checked and counted as above),
    `sensor_msgs/msg/Image` or `sensor_msgs/msg/CompressedImage` (each must decode; the first
    one's width/height, from a CompressedImage's PNG header, and encoding or format go in
    "source"), in log time order (equal times in the file's order); another type, or no such
    topic, is refused (exit 2). --bag-topic with a `.raw` SOURCE is refused too;
  - a Prophesee EVT 3.0 `.raw` file (its header: the leading `%` lines, up to a `% end` line if
    there is one): the words after the header are split into messages of --chunk-bytes bytes
    (default 65536, rounded down to an even number; the last message shorter) as Prophesee's
    `metavision_driver` publishes them: `encoding` "evt3", little-endian, `width`/`height` from
    the header (`% geometry WxH`, `% format EVT3;height=H;width=W`, or `% Width`/`% Height`),
    `seq` from 0, `time_base` 0, `header.frame_id` "camera", `header.stamp` = message index ms.

Events are counted by PyPI `evt3` (one stateful decoder fed every published payload in order);
without it, by the small EVT 3.0 word counter below (one event per ADDR_X word, one per set bit
of VECT_12's 12 and VECT_8's 8 valid bits). Errors: exit code 2, one line on stderr.

Run with the venv of deploy/setup.sh: tests/js/.venv/bin/python.
"""
import argparse
import dataclasses
import hashlib
import json
import struct
import sys
import threading
import time
import zlib
from collections import defaultdict
from pathlib import Path

import numpy as np
import zenoh
from zenoh.ext import Int64, z_serialize
from rosbags.rosbag2 import Reader

# The typestore and the DDS name mapping are check_live.py's, beside this file.
from check_live import record_attachment, ros_type, typestore

try:
    import evt3
except ImportError:  # the own counter below is used instead
    evt3 = None

EVENT_PACKET = "event_camera_msgs/msg/EventPacket"
IMAGE = "sensor_msgs/msg/Image"
COMPRESSED_IMAGE = "sensor_msgs/msg/CompressedImage"
FORWARDED_TYPES = (EVENT_PACKET, IMAGE, COMPRESSED_IMAGE)  # what --bag-topic may forward
BAG_TOPIC = "/O1/events"
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
PNG_CHANNELS = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}  # samples per pixel by colour type
NODE_NAME = "event_camera_driver"
QOS_VOLATILE = "::,:,:,:,,"  # ROS's default profile, as libs/ros2/src/rmw_zenoh.rs writes it
SUBSCRIBER_WAIT_S = 30.0
MATCH_WAIT_S = 5.0
QUIET_S = 1.5
AFTER_WITHDRAW_S = 2.0
LAST_QUIET_S = 0.3


def fail(message):
    print(" ".join(str(message).splitlines()), file=sys.stderr, flush=True)
    sys.exit(2)


def dds_type(msgtype):
    """`pkg/msg/Type` -> `pkg::msg::dds_::Type_`, the name rmw_zenoh puts in keys and tokens."""
    pkg, _msg, name = msgtype.split("/")
    return f"{pkg}::msg::dds_::{name}_"


def mangle(name):
    return name.replace("/", "%")


def plain(v):
    """A rosbags value as JSON-able Python: messages as dicts (no constants), arrays as lists."""
    if dataclasses.is_dataclass(v):
        return {f.name: plain(getattr(v, f.name)) for f in dataclasses.fields(v)
                if not f.name.startswith("__") and not f.name.isupper()}
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, (bytes, bytearray, memoryview)):
        return list(bytes(v))
    if isinstance(v, (list, tuple)):
        return [plain(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    return v


# --- counting events -----------------------------------------------------------------------------

def own_counter():
    """EVT 3.0 CD events in a word stream fed in pieces: one per ADDR_X (type 0x2), one per set
    bit of VECT_12 (0x4, 12 bits) and VECT_8 (0x5, 8 bits). Returns (feed, total)."""
    state = {"events": 0, "odd": b""}

    def feed(data):
        data = state["odd"] + bytes(data)
        even = len(data) - len(data) % 2
        state["odd"] = data[even:]
        words = np.frombuffer(data[:even], dtype="<u2")
        kind = words >> 12
        n = int(np.count_nonzero(kind == 0x2))
        for k, mask in ((0x4, 0xFFF), (0x5, 0xFF)):
            valid = (words[kind == k] & mask).astype(">u2").view(np.uint8)
            n += int(np.unpackbits(valid).sum())
        state["events"] += n

    return feed, lambda: state["events"]


def event_counter(width, height):
    """(feed, total, name): a stateful EVT 3.0 decoder fed every payload in order."""
    if evt3 is None:
        feed, total = own_counter()
        return feed, total, "own EVT 3.0 word counter"
    decoder = evt3.Decoder(sensor_width=width, sensor_height=height)
    state = {"events": 0}

    def feed(data):
        state["events"] += len(decoder.feed(bytes(data)))

    def total():
        rest = decoder.finish()
        if rest is not None:
            state["events"] += len(rest)
        return state["events"]

    return feed, total, f"evt3 {getattr(evt3, '__version__', '')}".strip()


# --- sources -------------------------------------------------------------------------------------

def raw_header(path, data):
    """The `%` lines of a Prophesee `.raw` file: ({key: value}, data start)."""
    lines, pos = [], 0
    while data[pos:pos + 1] == b"%":
        end = data.find(b"\n", pos)
        if end < 0:
            fail(f"{path}: header line at byte {pos} has no end")
        try:
            line = data[pos + 1:end].decode("ascii").strip()
        except UnicodeDecodeError:
            fail(f"{path}: header line at byte {pos} is not text")
        pos = end + 1
        if line == "end":
            break
        key, _, value = line.partition(" ")
        lines.append((key.lower(), value.strip()))
    header = {}
    for key, value in lines:
        header.setdefault(key, value)
    return header, pos


def raw_geometry(header):
    """(width, height) from `format NAME;width=W;height=H`, `geometry WxH` or `width`/`height`."""
    fields = dict(f.split("=", 1) for f in header.get("format", "").split(";") if "=" in f)
    try:
        if "width" in fields and "height" in fields:
            return int(fields["width"]), int(fields["height"])
        if "x" in header.get("geometry", ""):
            w, h = header["geometry"].split("x", 1)
            return int(w), int(h)
        if "width" in header and "height" in header:
            return int(header["width"]), int(header["height"])
    except ValueError:
        return None
    return None


def raw_source(path, chunk_bytes, store):
    data = path.read_bytes()
    header, start = raw_header(path, data)
    version, fmt = header.get("evt"), header.get("format")
    if version is not None and version != "3.0":
        fail(f"{path}: not an EVT 3.0 file (header `% evt {version}`)")
    if version is None and fmt is not None and not fmt.upper().startswith("EVT3"):
        fail(f"{path}: not an EVT 3.0 file (header `% format {fmt}`)")
    if version is None and fmt is None:
        fail(f"{path}: no `% evt 3.0` or `% format EVT3` header line: not known to be EVT 3.0")
    geometry = raw_geometry(header)
    if geometry is None or not all(0 < v <= 2048 for v in geometry):
        fail(f"{path}: no sensor size in the header (`% geometry WxH` or "
             f"`% format EVT3;height=H;width=W`)")
    width, height = geometry
    body = data[start:]
    if len(body) % 2:
        fail(f"{path}: the EVT 3.0 data after the header has an odd number of bytes ({len(body)})")
    step = max(2, chunk_bytes - chunk_bytes % 2)
    Time = store.types["builtin_interfaces/msg/Time"]
    Header = store.types["std_msgs/msg/Header"]
    Packet = store.types[EVENT_PACKET]
    feed, total, counter = event_counter(width, height)
    messages = []
    for seq, at in enumerate(range(0, len(body), step)):
        events = body[at:at + step]
        feed(events)
        msg = Packet(
            header=Header(stamp=Time(sec=seq // 1000, nanosec=(seq % 1000) * 1_000_000),
                          frame_id="camera"),
            height=height, width=width, seq=seq, time_base=0, encoding="evt3",
            is_bigendian=False, events=np.frombuffer(events, dtype=np.uint8))
        messages.append(bytes(store.serialize_cdr(msg, EVENT_PACKET)))
    return {"messages": messages, "type": EVENT_PACKET, "bytes": len(body), "events": total(),
            "counter": counter,
            "source": {"kind": "evt3 raw", "path": str(path), "width": width, "height": height,
                       "chunk_bytes": step, "header_bytes": start}}


def bag_source(path, store, bag_topic=None):
    """The raw CDR payloads of one topic of a ROS 2 bag: `bag_topic` (EventPacket, Image or
    CompressedImage), or without it `/O1/events` or the bag's only EventPacket topic."""
    try:
        with Reader(path) as reader:
            if bag_topic is None:
                msgtype = EVENT_PACKET
                topics = sorted({c.topic for c in reader.connections
                                 if c.msgtype == EVENT_PACKET})
                if BAG_TOPIC in topics:
                    topic = BAG_TOPIC
                elif len(topics) == 1:
                    topic = topics[0]
                else:
                    fail(f"{path}: {'no' if not topics else 'several'} {EVENT_PACKET} topics "
                         f"({', '.join(topics) or 'none'}) and none is {BAG_TOPIC}")
            else:
                topic = bag_topic
                types = sorted({c.msgtype for c in reader.connections if c.topic == topic})
                if not types:
                    topics = sorted({c.topic for c in reader.connections})
                    fail(f"{path}: no topic {topic} in the bag (its topics: "
                         f"{', '.join(topics) or 'none'})")
                if len(types) > 1:
                    fail(f"{path}: topic {topic} has several types ({', '.join(types)})")
                msgtype = types[0]
                if msgtype not in FORWARDED_TYPES:
                    fail(f"{path}: topic {topic} has type {msgtype}; --bag-topic forwards only "
                         f"{', '.join(FORWARDED_TYPES)}")
            conns = [c for c in reader.connections if c.topic == topic]
            stamped = [(t, bytes(raw)) for _c, t, raw in reader.messages(connections=conns)]
    except SystemExit:
        raise
    except Exception as e:  # noqa: BLE001 - any reader failure is the bag's
        fail(f"{path}: not a readable ROS 2 bag: {e}")
    if bag_topic is not None:
        # Log time, equal times in the reader's (the file's) order: rosbags yields one MCAP file
        # so already, but a directory's files one after the other.
        stamped.sort(key=lambda m: m[0])
    raws = [raw for _t, raw in stamped]
    if msgtype != EVENT_PACKET:
        return image_bag_source(path, store, topic, msgtype, raws)
    feed, total, counter, size, payload = None, None, None, None, 0
    for i, raw in enumerate(raws):
        try:
            msg = store.deserialize_cdr(raw, EVENT_PACKET)
        except Exception as e:  # noqa: BLE001
            fail(f"{path}: {topic} message {i}: CDR does not decode: {e}")
        if msg.encoding != "evt3" or msg.is_bigendian:
            fail(f"{path}: {topic} message {i}: encoding {msg.encoding!r}"
                 f"{' big-endian' if msg.is_bigendian else ''}, not little-endian evt3")
        if feed is None:
            size = (int(msg.width), int(msg.height))
            feed, total, counter = event_counter(*size)
        events = bytes(msg.events)
        payload += len(events)
        feed(events)
    source = {"kind": "ros2 bag", "path": str(path), "topic": topic,
              "width": size[0] if size else None, "height": size[1] if size else None}
    if bag_topic is not None:
        source["type"] = EVENT_PACKET
    return {"messages": raws, "type": EVENT_PACKET, "bytes": payload,
            "events": total() if total else 0, "counter": counter or "none (no messages)",
            "source": source}


def image_bag_source(path, store, topic, msgtype, raws):
    """A bag's Image or CompressedImage messages: each must decode; the first one's size (a
    CompressedImage's from its PNG header) and encoding or format are reported."""
    size, detail, payload = None, {}, 0
    for i, raw in enumerate(raws):
        try:
            msg = store.deserialize_cdr(raw, msgtype)
        except Exception as e:  # noqa: BLE001
            fail(f"{path}: {topic} message {i}: CDR does not decode as {msgtype}: {e}")
        data = bytes(msg.data)
        payload += len(data)
        if i == 0 and msgtype == IMAGE:
            size, detail = (int(msg.width), int(msg.height)), {"encoding": msg.encoding}
        elif i == 0:
            ihdr = png_header(data)
            size = ihdr[:2] if ihdr else None
            detail = {"format": msg.format}
    return {"messages": raws, "type": msgtype, "bytes": payload, "events": 0,
            "images": len(raws), "counter": "none (image messages)",
            "source": {"kind": "ros2 bag", "path": str(path), "topic": topic, "type": msgtype,
                       "width": size[0] if size else None, "height": size[1] if size else None,
                       **detail}}


# --- PNG, images, junk ---------------------------------------------------------------------------

def png_header(data):
    """(width, height, bit depth, colour type) from a PNG's IHDR, or None if not a PNG."""
    if data[:8] != PNG_SIGNATURE or len(data) < 33 or data[12:16] != b"IHDR":
        return None
    return struct.unpack(">IIBB", data[16:26])


def png_chunk(kind, body):
    return (struct.pack(">I", len(body)) + kind + body
            + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF))


def half_png(data):
    """A valid PNG of half the size of `data` (a PNG), same bit depth and colour type (and
    palette), all samples 0; None if `data` is not a PNG this can read the header of."""
    ihdr = png_header(data)
    if ihdr is None or ihdr[3] not in PNG_CHANNELS or ihdr[2] not in (1, 2, 4, 8, 16):
        return None
    width, height, depth, colour = ihdr
    w, h = max(1, width // 2), max(1, height // 2)
    row = (w * PNG_CHANNELS[colour] * depth + 7) // 8
    chunks = [png_chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, colour, 0, 0, 0))]
    if colour == 3:  # the original's palette
        at = 8
        while at + 12 <= len(data):
            (n,), kind = struct.unpack(">I", data[at:at + 4]), data[at + 4:at + 8]
            if kind == b"PLTE":
                chunks.append(png_chunk(b"PLTE", data[at + 8:at + 8 + n]))
                break
            at += 12 + n
        else:
            return None
    chunks.append(png_chunk(b"IDAT", zlib.compress(bytes(h * (1 + row)))))  # filter 0, zeros
    chunks.append(png_chunk(b"IEND", b""))
    return PNG_SIGNATURE + b"".join(chunks)


def half_image(msg):
    """A valid sensor_msgs Image of half the width and height: every other pixel of every other
    row (bytes per pixel = step // width), or zeros if the data does not fill height x step."""
    width, height, step = int(msg.width), int(msg.height), int(msg.step)
    w, h = max(1, width // 2), max(1, height // 2)
    data = np.asarray(msg.data, dtype=np.uint8)
    bpp = step // width if width else 0
    if bpp and height and data.size == height * step:
        pixels = data.reshape(height, step)[::2][:h, :width * bpp].reshape(h, width, bpp)
        out = np.ascontiguousarray(pixels[:, ::2][:, :w]).reshape(-1)
    else:
        bpp = max(1, bpp)
        out = np.zeros(h * w * bpp, dtype=np.uint8)
    return dataclasses.replace(msg, width=w, height=h, step=w * bpp, data=out)


def junk_messages(first, store, msgtype, source):
    """Three messages an observer must refuse, made from the first good one (CDR bytes): its CDR
    cut short, its copy in a wrong encoding (EventPacket: "mono"; Image: "yuv422";
    CompressedImage: format "jpeg"), and one of half its size (EventPacket: a sensor of half the
    size with no events; Image: every other pixel; CompressedImage: a PNG of half the size)."""
    msg = store.deserialize_cdr(first, msgtype)
    if msgtype == EVENT_PACKET:
        wrong = dataclasses.replace(msg, encoding="mono")
        small = dataclasses.replace(msg, width=max(1, msg.width // 2),
                                    height=max(1, msg.height // 2),
                                    events=np.zeros(0, dtype=np.uint8))
    elif msgtype == IMAGE:
        wrong = dataclasses.replace(msg, encoding="yuv422")
        small = half_image(msg)
    else:
        png = half_png(bytes(msg.data))
        if png is None:
            fail(f"{source}: --junk: the first {msgtype} is not a PNG whose size can be halved")
        wrong = dataclasses.replace(msg, format="jpeg")
        small = dataclasses.replace(msg, data=np.frombuffer(png, dtype=np.uint8))
    return [first[:10], bytes(store.serialize_cdr(wrong, msgtype)),
            bytes(store.serialize_cdr(small, msgtype))]


def load_source(source, chunk_bytes, store, bag_topic=None):
    path = Path(source)
    if not path.exists():
        fail(f"{path}: no such file or directory")
    if path.is_dir() or path.suffix == ".mcap":
        return bag_source(path, store, bag_topic)
    if bag_topic is not None:
        fail(f"{path}: --bag-topic {bag_topic} needs a ROS 2 bag SOURCE (a directory with "
             f"metadata.yaml, or its .mcap file)")
    return raw_source(path, chunk_bytes, store)


def count(source, chunk_bytes, bag_topic=None):
    src = load_source(source, chunk_bytes, typestore(), bag_topic)
    out = {"messages": len(src["messages"]), "events": src["events"]}
    if "images" in src:
        out["images"] = src["images"]
    print(json.dumps(out))


# --- publishing ----------------------------------------------------------------------------------

def token_parts(key):
    """`@ros2_lv/<domain>/<zid>/<node>/<entity>/<kind>/<enclave>/<ns>/<name>[/<topic>/<type>/
    <hash>/<qos>]` split at `/` (None if it has fewer than nine parts)."""
    parts = key.split("/")
    return parts if len(parts) >= 9 else None


def publish(endpoint, domain, topic, source, out_path, chunk_bytes, listen_s, junk,
            bag_topic=None):
    if not topic.startswith("/") or any(not p for p in topic[1:].split("/")):
        fail(f"topic {topic!r}: not an absolute ROS name such as /camera/events")
    store = typestore()
    src = load_source(source, chunk_bytes, store, bag_topic)
    msgtype = src["type"]
    outgoing = list(src["messages"])
    if junk:
        if not outgoing:
            fail(f"{source}: --junk needs at least one message to derive the junk from")
        outgoing[1:1] = junk_messages(outgoing[0], store, msgtype, source)
    type_hash = store.hash_rihs01(msgtype)
    type_dds = dds_type(msgtype)
    topic_m = mangle(topic)
    lock = threading.Lock()
    samples = defaultdict(lambda: {"count": 0, "decoded": 0, "errors": [], "seqs": [],
                                   "gids": set(), "stamps_ok": True, "types": None})
    frames, token_msgs = [], []
    tokens_seen, alive = [], {}
    last_sample = [time.monotonic()]
    ms_seen = threading.Event()
    ms_keys = set()
    observer_zids = set()

    def on_sample(sample):
        key = str(sample.key_expr)
        payload = sample.payload.to_bytes()
        att = sample.attachment
        with lock:
            last_sample[0] = time.monotonic()
            s = samples[key]
            s["count"] += 1
            record_attachment(s, att, keep_errors=5)
            parts = key.split("/")
            typename = ros_type(parts[-2]) if len(parts) >= 4 else None
            s["types"] = typename
            try:
                if typename is None or parts[0] != str(domain):
                    raise ValueError(f"key {key} is not DOMAIN/topic/dds type/hash")
                if store.hash_rihs01(typename) != parts[-1]:
                    raise ValueError(
                        f"type hash {parts[-1]} is not rosbags' {store.hash_rihs01(typename)}")
                msg = store.deserialize_cdr(payload, typename)
                s["decoded"] += 1
                if typename == "waggle_msgs/msg/Frame":
                    frames.append(plain(msg))
                elif typename == "waggle_msgs/msg/Token":
                    token_msgs.append(plain(msg))
            except Exception as e:  # noqa: BLE001
                if len(s["errors"]) < 5:
                    s["errors"].append(str(e))

    def on_token(sample):
        key = str(sample.key_expr)
        put = sample.kind == zenoh.SampleKind.PUT
        parts = token_parts(key)
        kind = parts[5] if parts else None
        with lock:
            tokens_seen.append({"key": key, "kind": kind, "state": "put" if put else "delete",
                                "ours": bool(parts) and parts[2] == own_zid})
            if put:
                alive[key] = parts
            else:
                alive.pop(key, None)
            if kind == "MS" and len(parts) > 9 and parts[9] == topic_m:
                if put:
                    ms_keys.add(key)
                    observer_zids.add(parts[2])
                    ms_seen.set()
                else:
                    ms_keys.discard(key)

    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("listen/endpoints", json.dumps([endpoint]))
    config.insert_json5("scouting/multicast/enabled", "false")
    try:
        session = zenoh.open(config)
    except Exception as e:  # noqa: BLE001
        fail(f"cannot listen on {endpoint}: {e}")
    with session:
        own_zid = str(session.info.zid())
        sub = session.declare_subscriber(f"{domain}/**", on_sample,
                                         allowed_origin=zenoh.Locality.REMOTE)
        lv = session.liveliness().declare_subscriber(f"@ros2_lv/{domain}/**", on_token,
                                                     history=True)
        print("ready", flush=True)
        if not ms_seen.wait(SUBSCRIBER_WAIT_S):
            fail(f"no subscription token (MS) for {topic} on @ros2_lv/{domain}/** within "
                 f"{SUBSCRIBER_WAIT_S:.0f} s: no observer subscribed")
        with lock:
            ms_tokens = sorted(ms_keys)

        prefix = f"@ros2_lv/{domain}/{own_zid}/0"
        nn_token = f"{prefix}/0/NN/%/%/{NODE_NAME}"
        mp_token = (f"{prefix}/1/MP/%/%/{NODE_NAME}/{topic_m}/{type_dds}/{type_hash}/"
                    f"{QOS_VOLATILE}")
        gid = hashlib.sha256(mp_token.encode()).digest()[:16]
        key = f"{domain}/{topic.strip('/')}/{type_dds}/{type_hash}"
        nn = session.liveliness().declare_token(nn_token)
        mp = session.liveliness().declare_token(mp_token)
        pub = session.declare_publisher(key, congestion_control=zenoh.CongestionControl.BLOCK,
                                        reliability=zenoh.Reliability.RELIABLE,
                                        allowed_destination=zenoh.Locality.REMOTE)
        deadline = time.monotonic() + MATCH_WAIT_S
        while not pub.matching_status and time.monotonic() < deadline:
            time.sleep(0.02)
        matched = bool(pub.matching_status)

        started = time.monotonic()
        for seq, cdr in enumerate(outgoing, start=1):
            att = z_serialize((Int64(seq), Int64(time.time_ns()), gid))
            pub.put(cdr, attachment=att)
        published = time.monotonic()

        # The observer's output: until it has been quiet for QUIET_S (at most listen_s).
        while time.monotonic() < published + listen_s:
            with lock:
                last = max(last_sample[0], published)
            if time.monotonic() - last >= QUIET_S:
                break
            time.sleep(0.05)

        pub.undeclare()
        mp.undeclare()
        nn.undeclare()
        withdrawn = time.monotonic()
        # The observer ends once our MP token is gone, and publishes its last outputs (the rest
        # of its tail) after dropping its subscription: wait until its session has no token left
        # and its samples have stopped.
        observer_left = False
        while time.monotonic() < withdrawn + max(AFTER_WITHDRAW_S, listen_s):
            with lock:
                observer_left = not any(parts and parts[2] in observer_zids
                                        for parts in alive.values())
                quiet = time.monotonic() - last_sample[0] >= LAST_QUIET_S
            if observer_left and quiet:
                break
            time.sleep(0.05)

        with lock:
            live_topics = defaultdict(set)
            for parts in alive.values():
                if parts and len(parts) > 10:
                    live_topics[(parts[9], parts[10])].add(parts[5])
            for t in tokens_seen:  # tokens withdrawn by now still named their topic
                parts = token_parts(t["key"])
                if parts and len(parts) > 10 and t["state"] == "put":
                    live_topics[(parts[9], parts[10])].add(parts[5])
            received = {}
            for k, s in samples.items():
                kparts = k.split("/")
                ktopic = mangle("/" + "/".join(kparts[1:-2])) if len(kparts) >= 4 else None
                received[k] = {
                    "count": s["count"],
                    "decoded": s["decoded"],
                    "errors": s["errors"],
                    "types": s["types"],
                    "tokens_kinds": sorted(live_topics.get((ktopic, kparts[-2]), ())),
                    "seqs_ok": s["seqs"] == list(range(1, len(s["seqs"]) + 1)),
                    "one_gid": len(s["gids"]) == 1,
                    "stamps_ok": s["stamps_ok"],
                }
            report = {
                "messages": len(src["messages"]),
                "junk": len(outgoing) - len(src["messages"]),
                "observer_left": observer_left,
                "bytes": src["bytes"],
                "events": src["events"],
                "counter": src["counter"],
                "source": src["source"],
                "type_hash": type_hash,
                "publish_key": key,
                "nn_token": nn_token,
                "mp_token": mp_token,
                "ms_tokens": ms_tokens,
                "matched": matched,
                "publish_s": round(published - started, 3),
                "received": received,
                "frames": list(frames),
                "tokens": list(token_msgs),
                "received_tokens": list(tokens_seen),
            }
            if "images" in src:
                report["images"] = src["images"]
        sub.undeclare()
        lv.undeclare()
    Path(out_path).write_text(json.dumps(report, sort_keys=True))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("publish")
    p.add_argument("endpoint")
    p.add_argument("domain", type=int)
    p.add_argument("topic")
    p.add_argument("source")
    p.add_argument("out_json")
    p.add_argument("--chunk-bytes", type=int, default=65536)
    p.add_argument("--listen-s", type=float, default=10.0)
    p.add_argument("--junk", action="store_true")
    p.add_argument("--bag-topic")
    c = sub.add_parser("count")
    c.add_argument("source")
    c.add_argument("--chunk-bytes", type=int, default=65536)
    c.add_argument("--bag-topic")
    args = parser.parse_args()
    if args.chunk_bytes < 2:
        fail(f"--chunk-bytes {args.chunk_bytes}: at least 2")
    if args.command == "count":
        count(args.source, args.chunk_bytes, args.bag_topic)
    else:
        if args.listen_s < 0:
            fail(f"--listen-s {args.listen_s}: not negative")
        publish(args.endpoint, args.domain, args.topic, args.source, args.out_json,
                args.chunk_bytes, args.listen_s, args.junk, args.bag_topic)


if __name__ == "__main__":
    main()
