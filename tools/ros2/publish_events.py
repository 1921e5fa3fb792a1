"""A ROS 2 event camera driver for `waggle observe`, written with independent code: Eclipse Zenoh's
own Python client publishes `event_camera_msgs/msg/EventPacket` messages as a node on ROS 2
Jazzy's `rmw_zenoh` middleware would, PyPI `rosbags` serializes and decodes them, and PyPI `evt3`
counts the events they carry.

  publish_events.py publish ENDPOINT DOMAIN TOPIC SOURCE OUT_JSON [--chunk-bytes N] [--listen-s S]
                    [--junk]
      A Zenoh peer listening on ENDPOINT (`tcp/127.0.0.1:PORT`; the observer connects to it as
      to `rmw_zenohd`), multicast scouting off. Prints "ready" once subscribed to every sample on
      `DOMAIN/**` and to the liveliness tokens on `@ros2_lv/DOMAIN/**` (history included), then:
      - waits (at most 30 s) for a subscription token (`MS`) of TOPIC (e.g. `/camera/events`,
        mangled `%camera%events`): the observer's;
      - declares its own tokens as rmw_zenoh does: node `event_camera_driver` (`NN`) and its
        publisher of TOPIC (`MP`, type `event_camera_msgs::msg::dds_::EventPacket_`, the RIHS01
        hash rosbags computes for it, volatile QoS);
      - publishes every message of SOURCE on `DOMAIN/<topic>/event_camera_msgs::msg::dds_::
        EventPacket_/RIHS01_<hash>`, reliable, congestion control BLOCK, each with the rmw_zenoh
        attachment (int64 sequence number from 1, int64 source timestamp = wall clock ns, the
        publisher's 16-byte GID) serialized with `zenoh.ext.z_serialize`; with --junk, three
        malformed messages follow the first one: CDR cut short, `encoding` "mono", and a sensor
        of half the size (e.g. 320x240 after 640x480) with no events;
      - waits for the observer's samples to stop (1.5 s with nothing new, at most --listen-s,
        default 10 s, after the last message), withdraws its MP and NN tokens (the observer ends
        when every publisher of its topic is gone) and keeps listening until the observer's
        session has withdrawn all its tokens (it publishes its last outputs after dropping its
        subscription) and 0.3 s more without a sample, at most max(2 s, --listen-s);
      - writes OUT_JSON: {"messages" (the source's, junk not counted), "junk" (0 or 3), "bytes"
        (event payload bytes), "events" (CD events in what was published), "received": {KEY:
        {"count", "decoded", "errors", "types" (the ROS type), "tokens_kinds" (kinds of the
        tokens seen naming that topic and type), "seqs_ok", "one_gid", "stamps_ok"}},
        "frames" and "tokens" (every waggle_msgs/msg/Frame and waggle_msgs/msg/Token received,
        all fields, in arrival order), "received_tokens"
        ([{"key", "kind", "state": "put"|"delete", "ours"}] in arrival order), and details
        ("source", "counter", "type_hash", "publish_key", "nn_token", "mp_token", "ms_tokens",
        "matched" (a subscriber matched the publisher before the first message), "publish_s",
        "observer_left")}.

  publish_events.py count SOURCE [--chunk-bytes N]
      Prints {"messages": N, "events": E} for SOURCE, split and counted as `publish` does,
      without any networking.

SOURCE is either
  - a ROS 2 bag written by `waggle export ros2` (a directory with metadata.yaml, or its `.mcap`
    file): the raw CDR payloads of its `/O1/events` topic (or of its only EventPacket topic) are
    forwarded unchanged, in the bag's order;
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
import sys
import threading
import time
from collections import defaultdict
from pathlib import Path

import numpy as np
import zenoh
from zenoh.ext import Int64, z_deserialize, z_serialize
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore, get_types_from_msg

try:
    import evt3
except ImportError:  # the own counter below is used instead
    evt3 = None

MSG_ROOT = Path(__file__).resolve().parents[2] / "libs" / "ros2" / "msg"
EVENT_PACKET = "event_camera_msgs/msg/EventPacket"
EVENT_PACKET_DDS = "event_camera_msgs::msg::dds_::EventPacket_"
BAG_TOPIC = "/O1/events"
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


def typestore():
    """ROS 2 Jazzy's types, plus the repository's definitions of the ones rosbags lacks."""
    store = get_typestore(Stores.ROS2_JAZZY)
    for msg in sorted(MSG_ROOT.rglob("*.msg")):
        name = f"{msg.parent.parent.name}/msg/{msg.stem}"
        if name in store.types:
            continue
        store.register(get_types_from_msg(msg.read_text(), name))
    return store


def ros_type(dds):
    """`pkg::msg::dds_::Type_` -> `pkg/msg/Type` (None if not that shape)."""
    parts = dds.split("::")
    if len(parts) != 4 or parts[1] != "msg" or parts[2] != "dds_" or not parts[3].endswith("_"):
        return None
    return f"{parts[0]}/msg/{parts[3][:-1]}"


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
    return {"messages": messages, "bytes": len(body), "events": total(), "counter": counter,
            "source": {"kind": "evt3 raw", "path": str(path), "width": width, "height": height,
                       "chunk_bytes": step, "header_bytes": start}}


def bag_source(path, store):
    try:
        with Reader(path) as reader:
            topics = sorted({c.topic for c in reader.connections if c.msgtype == EVENT_PACKET})
            if BAG_TOPIC in topics:
                topic = BAG_TOPIC
            elif len(topics) == 1:
                topic = topics[0]
            else:
                fail(f"{path}: {'no' if not topics else 'several'} {EVENT_PACKET} topics "
                     f"({', '.join(topics) or 'none'}) and none is {BAG_TOPIC}")
            conns = [c for c in reader.connections if c.topic == topic]
            raws = [bytes(raw) for _c, _t, raw in reader.messages(connections=conns)]
    except SystemExit:
        raise
    except Exception as e:  # noqa: BLE001 - any reader failure is the bag's
        fail(f"{path}: not a readable ROS 2 bag: {e}")
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
    return {"messages": raws, "bytes": payload, "events": total() if total else 0,
            "counter": counter or "none (no messages)",
            "source": {"kind": "ros2 bag", "path": str(path), "topic": topic,
                       "width": size[0] if size else None, "height": size[1] if size else None}}


def junk_messages(first, store):
    """Three messages an observer must refuse, made from the first good one (CDR bytes): its CDR
    cut short, its copy with encoding "mono", and a sensor of half its size with no events."""
    msg = store.deserialize_cdr(first, EVENT_PACKET)
    mono = dataclasses.replace(msg, encoding="mono")
    small = dataclasses.replace(msg, width=max(1, msg.width // 2), height=max(1, msg.height // 2),
                                events=np.zeros(0, dtype=np.uint8))
    return [first[:10], bytes(store.serialize_cdr(mono, EVENT_PACKET)),
            bytes(store.serialize_cdr(small, EVENT_PACKET))]


def load_source(source, chunk_bytes, store):
    path = Path(source)
    if not path.exists():
        fail(f"{path}: no such file or directory")
    if path.is_dir() or path.suffix == ".mcap":
        return bag_source(path, store)
    return raw_source(path, chunk_bytes, store)


def count(source, chunk_bytes):
    src = load_source(source, chunk_bytes, typestore())
    print(json.dumps({"messages": len(src["messages"]), "events": src["events"]}))


# --- publishing ----------------------------------------------------------------------------------

def token_parts(key):
    """`@ros2_lv/<domain>/<zid>/<node>/<entity>/<kind>/<enclave>/<ns>/<name>[/<topic>/<type>/
    <hash>/<qos>]` split at `/` (None if it has fewer than nine parts)."""
    parts = key.split("/")
    return parts if len(parts) >= 9 else None


def publish(endpoint, domain, topic, source, out_path, chunk_bytes, listen_s, junk):
    if not topic.startswith("/") or any(not p for p in topic[1:].split("/")):
        fail(f"topic {topic!r}: not an absolute ROS name such as /camera/events")
    store = typestore()
    src = load_source(source, chunk_bytes, store)
    outgoing = list(src["messages"])
    if junk:
        if not outgoing:
            fail(f"{source}: --junk needs at least one message to derive the junk from")
        outgoing[1:1] = junk_messages(outgoing[0], store)
    type_hash = store.hash_rihs01(EVENT_PACKET)
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
            try:
                seq, stamp, gid = z_deserialize(tuple[Int64, Int64, bytes], att)
                s["seqs"].append(int(seq))
                s["gids"].add(bytes(gid).hex())
                if len(gid) != 16 or stamp <= 0:
                    s["stamps_ok"] = False
            except Exception as e:  # noqa: BLE001 - reported, not fatal
                if len(s["errors"]) < 5:
                    s["errors"].append(f"attachment: {e}")
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
        mp_token = (f"{prefix}/1/MP/%/%/{NODE_NAME}/{topic_m}/{EVENT_PACKET_DDS}/{type_hash}/"
                    f"{QOS_VOLATILE}")
        gid = hashlib.sha256(mp_token.encode()).digest()[:16]
        key = f"{domain}/{topic.strip('/')}/{EVENT_PACKET_DDS}/{type_hash}"
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
    c = sub.add_parser("count")
    c.add_argument("source")
    c.add_argument("--chunk-bytes", type=int, default=65536)
    args = parser.parse_args()
    if args.chunk_bytes < 2:
        fail(f"--chunk-bytes {args.chunk_bytes}: at least 2")
    if args.command == "count":
        count(args.source, args.chunk_bytes)
    else:
        if args.listen_s < 0:
            fail(f"--listen-s {args.listen_s}: not negative")
        publish(args.endpoint, args.domain, args.topic, args.source, args.out_json,
                args.chunk_bytes, args.listen_s, args.junk)


if __name__ == "__main__":
    main()
