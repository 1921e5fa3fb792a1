"""Independent AEDAT4 reader and writer for Waggle's cross-checks (tests/tests/ingest.rs), run in
the venv deploy/setup.sh makes (tests/js/.venv: pinned PyPI dv-processing and aedat).

    aedat4_check.py read FILE.aedat4
        Reads the file's event stream with iniVation's dv-processing (dv.io.MonoCameraRecording)
        and with the `aedat` package, and prints, as JSON per reader, the sensor size, the event
        count, the last timestamp (µs) and an order-sensitive checksum of (t_us, x, y, polarity)
        that the Rust test computes the same way.
    aedat4_check.py write EVENTS.bin OUT.aedat4 WIDTH HEIGHT COMPRESSION
        Writes the events of EVENTS.bin (16-byte records: int64 t_us, int16 x, int16 y, uint8
        polarity, 3 bytes of padding) with dv-processing's dv.io.MonoCameraWriter, COMPRESSION one
        of NONE, LZ4, LZ4_HIGH, ZSTD, ZSTD_HIGH.
"""
import json
import sys

import aedat
import dv_processing as dv
import numpy as np

RECORD = np.dtype([("t", "<i8"), ("x", "<i2"), ("y", "<i2"), ("p", "u1"), ("pad", "V3")])


def summary(width, height, t, x, y, p):
    t, x, y, p = (np.asarray(a).astype(np.uint64) for a in (t, x, y, p))
    i = np.arange(1, len(t) + 1, dtype=np.uint64)
    with np.errstate(over="ignore"):
        check = (t * np.uint64(1_000_003) + x * np.uint64(1009) + y * np.uint64(17) + p) * i
        check = int(check.sum(dtype=np.uint64))
    return {"width": int(width), "height": int(height), "events": int(len(t)),
            "checksum": check, "last_t_us": int(t[-1]) if len(t) else None}


def read_dv(path):
    rec = dv.io.MonoCameraRecording(path)
    width, height = rec.getEventResolution()
    parts = []
    while True:
        batch = rec.getNextEventBatch()
        if batch is None:
            break
        parts.append(batch.numpy())
    ev = np.concatenate(parts) if parts else np.zeros(0, dtype=RECORD)
    return summary(width, height, ev["timestamp"], ev["x"], ev["y"], ev["polarity"])


def read_aedat(path):
    decoder = aedat.Decoder(path)
    streams = {i: s for i, s in decoder.id_to_stream().items() if s["type"] == "events"}
    sid = min(streams)
    parts = [p["events"] for p in decoder if p["stream_id"] == sid and "events" in p]
    ev = np.concatenate(parts) if parts else np.zeros(0, dtype=[("t", "<u8"), ("x", "<u2"), ("y", "<u2"), ("on", "?")])
    return summary(streams[sid]["width"], streams[sid]["height"], ev["t"], ev["x"], ev["y"], ev["on"])


def write(events_bin, out, width, height, compression):
    ev = np.fromfile(events_bin, dtype=RECORD)
    config = dv.io.MonoCameraWriter.Config("Waggle", getattr(dv.CompressionType, compression))
    config.addEventStream((int(width), int(height)))
    writer = dv.io.MonoCameraWriter(out, config)
    # Batches of 10 000 events, as a camera's packets would come.
    for start in range(0, len(ev), 10_000):
        store = dv.EventStore()
        for t, x, y, p, _ in ev[start:start + 10_000].tolist():
            store.push_back(t, x, y, bool(p))
        writer.writeEvents(store)
    del writer


if __name__ == "__main__":
    if sys.argv[1] == "read":
        print(json.dumps({"dv_processing": read_dv(sys.argv[2]), "aedat": read_aedat(sys.argv[2])}))
    elif sys.argv[1] == "write":
        write(*sys.argv[2:7])
    else:
        sys.exit(__doc__)
