"""The ROS 2 side of Waggle's live view (`waggle run --ros2-domain N`), checked with independent
code: Eclipse Zenoh's own Python client receives what the recorder publishes, as an `rmw_zenoh`
node would, and PyPI `rosbags` decodes it.

  check_live.py listen ENDPOINT DOMAIN OUT_JSON
      A Zenoh peer listening on ENDPOINT (the recorder connects to it as to `rmw_zenohd`).
      Prints "ready" once subscribed, then collects until its standard input closes:
      - every sample on `DOMAIN/**`: its key must be `DOMAIN/<topic>/<pkg>::msg::dds_::<Type>_/
        RIHS01_<hash>` with the hash rosbags computes for the type (ROS 2 Jazzy's type store,
        the non-standard types registered from libs/ros2/msg/); its payload must decode with
        rosbags' CDR deserializer; its attachment must decode with Zenoh's own deserializer as
        (int64 sequence number, int64 source timestamp, 16-byte GID), the sequence numbers
        counting 1, 2, 3… per key and the GID constant per key;
      - every liveliness token on `@ros2_lv/DOMAIN/**` (history included).
      Writes OUT_JSON: per key the count, the checks and the SHA-256 of each payload; the tokens.

  check_live.py compare OUT_JSON BAG_DIR
      Reads the bag `waggle export ros2` made of the same run with rosbags and prints JSON: per
      topic, the live and bag message counts and whether the live payloads equal the bag's
      (as multisets of SHA-256), and which topics only one side has.

Run with the venv of deploy/setup.sh: tests/js/.venv/bin/python.
"""
import hashlib
import json
import sys
import threading
import time
from collections import defaultdict
from pathlib import Path

import zenoh
from zenoh.ext import Int64, z_deserialize
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore, get_types_from_msg

MSG_ROOT = Path(__file__).resolve().parents[2] / "libs" / "ros2" / "msg"


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


def record_attachment(s, attachment, keep_errors=None):
    """Reads an rmw_zenoh attachment (int64 sequence number, int64 source timestamp, 16-byte GID)
    into a key's record `s`: its sequence numbers, GIDs and whether stamps are sane; a failure
    goes to `s["errors"]` (the first `keep_errors` of them, all when None)."""
    try:
        seq, stamp, gid = z_deserialize(tuple[Int64, Int64, bytes], attachment)
        s["seqs"].append(int(seq))
        s["gids"].add(bytes(gid).hex())
        if len(gid) != 16 or stamp <= 0:
            s["stamps_ok"] = False
    except Exception as e:  # noqa: BLE001 - reported, not fatal
        if keep_errors is None or len(s["errors"]) < keep_errors:
            s["errors"].append(f"attachment: {e}")


def listen(endpoint, domain, out_path):
    store = typestore()
    lock = threading.Lock()
    samples = defaultdict(lambda: {"count": 0, "seqs": [], "gids": set(), "stamps_ok": True,
                                   "decoded": 0, "errors": [], "sha256": []})
    tokens = {"put": [], "delete": []}

    def on_sample(sample):
        key = str(sample.key_expr)
        payload = sample.payload.to_bytes()
        with lock:
            s = samples[key]
            s["count"] += 1
            s["sha256"].append(hashlib.sha256(payload).hexdigest())
            record_attachment(s, sample.attachment)
            parts = key.split("/")
            typename = ros_type(parts[-2]) if len(parts) >= 4 else None
            try:
                if typename is None or parts[0] != str(domain):
                    raise ValueError(f"key {key} is not DOMAIN/topic/dds type/hash")
                if store.hash_rihs01(typename) != parts[-1]:
                    raise ValueError(f"type hash {parts[-1]} is not rosbags' {store.hash_rihs01(typename)}")
                store.deserialize_cdr(payload, typename)
                s["decoded"] += 1
            except Exception as e:  # noqa: BLE001
                if len(s["errors"]) < 5:
                    s["errors"].append(str(e))

    def on_token(sample):
        with lock:
            kind = "put" if sample.kind == zenoh.SampleKind.PUT else "delete"
            tokens[kind].append(str(sample.key_expr))

    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("listen/endpoints", json.dumps([endpoint]))
    config.insert_json5("scouting/multicast/enabled", "false")
    with zenoh.open(config) as session:
        sub = session.declare_subscriber(f"{domain}/**", on_sample)
        lv = session.liveliness().declare_subscriber(f"@ros2_lv/{domain}/**", on_token, history=True)
        print("ready", flush=True)
        sys.stdin.read()
        time.sleep(1.0)
        with lock:
            report = {"samples": {}, "tokens": {k: sorted(v) for k, v in tokens.items()}}
            for key, s in samples.items():
                report["samples"][key] = {
                    "count": s["count"],
                    "seqs_ok": s["seqs"] == list(range(1, len(s["seqs"]) + 1)),
                    "one_gid": len(s["gids"]) == 1,
                    "gid": sorted(s["gids"])[0] if s["gids"] else None,
                    "stamps_ok": s["stamps_ok"],
                    "decoded": s["decoded"],
                    "errors": s["errors"],
                    "sha256": s["sha256"],
                }
        sub.undeclare()
        lv.undeclare()
    Path(out_path).write_text(json.dumps(report, sort_keys=True))


def compare(live_path, bag_dir):
    live = json.loads(Path(live_path).read_text())
    by_topic = {}
    for key, s in live["samples"].items():
        topic = "/" + "/".join(key.split("/")[1:-2])
        by_topic[topic] = s
    bag = defaultdict(list)
    with Reader(bag_dir) as reader:
        for conn, _t, raw in reader.messages():
            bag[conn.topic].append(hashlib.sha256(raw).hexdigest())
    report = {"topics": {}, "only_live": sorted(set(by_topic) - set(bag)),
              "only_bag": sorted(set(bag) - set(by_topic))}
    for topic in sorted(set(by_topic) & set(bag)):
        lv = by_topic[topic]["sha256"]
        report["topics"][topic] = {"live": len(lv), "bag": len(bag[topic]),
                                   "same": sorted(lv) == sorted(bag[topic])}
    print(json.dumps(report, sort_keys=True))


if __name__ == "__main__":
    if len(sys.argv) == 5 and sys.argv[1] == "listen":
        listen(sys.argv[2], int(sys.argv[3]), sys.argv[4])
    elif len(sys.argv) == 4 and sys.argv[1] == "compare":
        compare(sys.argv[2], sys.argv[3])
    else:
        sys.exit(__doc__)
