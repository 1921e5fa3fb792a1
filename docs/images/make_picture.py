"""Composes docs/images/scene-and-events.png from one recorded event-camera run: on the left the
RGB render that observer O1's event sensor was fed at the end of a short window, on the right
the events that sensor produced over the window, accumulated into an image.

    make_picture.py RUN_DIR BAG_DIR OUT.png --end-s T --window-ms W

RUN_DIR is a `waggle run ... --modality events --record-events input` directory: its
session.mcap holds the sensor's input, `/camera/O1/input` (RGB updates: a key frame, then the
changed rectangles). BAG_DIR is `waggle export ros2 RUN_DIR --out BAG_DIR`, whose `/O1/events`
holds the packets regenerated from that input (CDR `event_camera_msgs/msg/EventPacket`, EVT 3.0
payloads). Both are decoded here with the mcap reader and struct (Waggle's bincode messages,
CDR, EVT 3.0 words), no Waggle code. Run by make-picture.sh, which fixes the case, seed and
window.
"""

import argparse
import glob
import os
import struct

import numpy as np
from mcap.reader import make_reader
from PIL import Image, ImageDraw, ImageFont

WIDTH, HEIGHT = 640, 480  # the observers' cameras (proto::scene)
OBSERVER = "O1"
FORMAT_VERSION = 2  # proto's wire format (proto/src/wire/codec.rs)

# Layout: two panels of the same crop around the performer, each pixel drawn 4 x 4, each with a
# caption strip below it.
CROP_W, CROP_H, SCALE = 110, 82, 4  # 440 x 328 on the sheet
GAP, MARGIN, CAPTION_H = 12, 8, 26
BACKGROUND = (255, 255, 255)
EVENT_BACKGROUND = (16, 18, 24)
ON_COLOUR = (90, 180, 255)
OFF_COLOUR = (255, 96, 64)
TEXT = (30, 30, 30)


# --- the sensor's input: waggle.RgbUpdate (bincode, fixint, little-endian) ---------------------


def rgb_update(data):
    """(seq, stamp_ns, base_seq or None, (x, y, w, h), pixels) of one RgbUpdate."""
    (version,) = struct.unpack_from("<H", data, 0)
    if version != FORMAT_VERSION:
        raise SystemExit(f"wire format version {version}, this script reads {FORMAT_VERSION}")
    seq, stamp_ns, width, height, _valid, _continuous = struct.unpack_from("<QQHHBB", data, 2)
    if (width, height) != (WIDTH, HEIGHT):
        raise SystemExit(f"a {width}x{height} render, expected {WIDTH}x{HEIGHT}")
    off = 2 + 22
    (tag,) = struct.unpack_from("<B", data, off)
    off += 1
    base = None
    if tag == 1:
        (base,) = struct.unpack_from("<Q", data, off)
        off += 8
    rect = struct.unpack_from("<HHHH", data, off)
    off += 8
    (n,) = struct.unpack_from("<Q", data, off)
    off += 8
    pixels = np.frombuffer(data, dtype=np.uint8, count=n, offset=off)
    return seq, stamp_ns, base, rect, pixels


def render_at(session_mcap, t_ns):
    """The render stamped exactly t_ns, rebuilt from the last key frame before it (the input
    holds one every few seconds, so this reads from the start)."""
    held, held_seq = None, None
    with open(session_mcap, "rb") as f:
        reader = make_reader(f)
        for _, _, msg in reader.iter_messages(
            topics=[f"/camera/{OBSERVER}/input"], ending_at=t_ns
        ):
            seq, stamp_ns, base, (x, y, w, h), pixels = rgb_update(msg.data)
            if stamp_ns > t_ns:
                break
            if base is None:
                held = pixels.reshape(HEIGHT, WIDTH, 3).copy()
            elif held is not None and base == held_seq:
                held[y : y + h, x : x + w] = pixels.reshape(h, w, 3)
            else:
                held = None  # an update for a frame we do not hold: wait for a key frame
            held_seq = seq
            if stamp_ns == t_ns and held is not None:
                return held
    raise SystemExit(f"no render of {OBSERVER} stamped {t_ns} ns in {session_mcap}")


# --- the events: event_camera_msgs/msg/EventPacket (CDR) with an EVT 3.0 payload ---------------


def event_packet(data):
    """(stamp_ns, encoding, payload) of one CDR EventPacket."""
    body = memoryview(data)[4:]  # after the CDR encapsulation header; alignment counts from here
    off = 0

    def align(n):
        nonlocal off
        off = (off + n - 1) // n * n

    def scalar(fmt):
        nonlocal off
        size = struct.calcsize(fmt)
        align(size)
        (v,) = struct.unpack_from(fmt, body, off)
        off += size
        return v

    def u32():
        return scalar("<I")

    def u64():
        return scalar("<Q")

    def string():
        nonlocal off
        n = u32()
        s = bytes(body[off : off + n - 1]).decode()
        off += n
        return s

    sec, nanosec = u32(), u32()
    string()  # frame_id
    height, width = u32(), u32()
    if (width, height) != (WIDTH, HEIGHT):
        raise SystemExit(f"a {width}x{height} event packet, expected {WIDTH}x{HEIGHT}")
    u64()  # seq
    time_base = u64()
    encoding = string()
    off += 1  # is_bigendian
    n = u32()
    return sec * 1_000_000_000 + nanosec, time_base, encoding, bytes(body[off : off + n])


def evt3_events(payload, near_us):
    """(t_us, x, y, on) of an EVT 3.0 word stream that starts with its time and row, as each of
    Waggle's packets does. The 24-bit clock is unwrapped to the wrap nearest near_us."""
    words = np.frombuffer(payload, dtype="<u2")
    out = []
    y = x_base = pol = t_high = t_low = 0
    for w in words.tolist():
        kind, v = w >> 12, w & 0x0FFF
        if kind == 0x0:  # EVT_ADDR_Y
            y = v & 0x7FF
        elif kind == 0x2:  # EVT_ADDR_X: one event
            out.append((t_high << 12 | t_low, v & 0x7FF, y, v >> 11))
        elif kind == 0x3:  # VECT_BASE_X
            x_base, pol = v & 0x7FF, v >> 11
        elif kind in (0x4, 0x5):  # VECT_12, VECT_8: a run of events from x_base
            bits = 12 if kind == 0x4 else 8
            for i in range(bits):
                if v >> i & 1:
                    out.append((t_high << 12 | t_low, x_base + i, y, pol))
            x_base += bits
        elif kind == 0x6:  # TIME_LOW
            t_low = v
        elif kind == 0x8:  # TIME_HIGH
            t_high = v
    wrap = 1 << 24
    events = []
    for t24, x, y_, on in out:
        t = t24 + (near_us - t24 + wrap // 2) // wrap * wrap
        events.append((t, x, y_, on))
    return events


def events_in(bag_dir, start_ns, end_ns):
    """Every event of O1 with start_ns < t <= end_ns (at the microsecond resolution of EVT 3.0)."""
    (path,) = glob.glob(os.path.join(bag_dir, "*.mcap"))
    found = []
    with open(path, "rb") as f:
        reader = make_reader(f)
        for _, _, msg in reader.iter_messages(
            topics=[f"/{OBSERVER}/events"],
            starting_at=max(0, start_ns - 100_000_000),
            ending_at=end_ns,
        ):
            stamp_ns, time_base, encoding, payload = event_packet(msg.data)
            if encoding != "evt3":
                raise SystemExit(f"events encoded {encoding!r}, this script reads evt3")
            for t_us, x, y, on in evt3_events(payload, stamp_ns // 1000):
                t_ns = (time_base + t_us) * 1000
                if start_ns < t_ns <= end_ns:
                    found.append((t_ns, x, y, on))
    found.sort(key=lambda e: e[0])
    return found


# --- the sheet ----------------------------------------------------------------------------------


def event_image(events):
    """The window's events on a dark background, each pixel the colour of its last event."""
    img = np.empty((HEIGHT, WIDTH, 3), dtype=np.uint8)
    img[:] = EVENT_BACKGROUND
    for _, x, y, on in events:  # in time order, so the last event of a pixel wins
        img[y, x] = ON_COLOUR if on else OFF_COLOUR
    return img


def crop_around(events):
    """The crop's top-left corner: centred on the window's events (the moving performer)."""
    cx = round(sum(e[1] for e in events) / len(events))
    cy = round(sum(e[2] for e in events) / len(events))
    x0 = min(max(cx - CROP_W // 2, 0), WIDTH - CROP_W)
    y0 = min(max(cy - CROP_H // 2, 0), HEIGHT - CROP_H)
    return x0, y0


def panel(rgb, corner):
    x0, y0 = corner
    crop = Image.fromarray(rgb[y0 : y0 + CROP_H, x0 : x0 + CROP_W])
    return crop.resize((CROP_W * SCALE, CROP_H * SCALE), Image.Resampling.NEAREST)


def compose(render, events, end_ns, window_ms, out):
    corner = crop_around(events)
    left, right = panel(render, corner), panel(event_image(events), corner)
    w, h = left.size
    sheet = Image.new("RGB", (2 * w + GAP + 2 * MARGIN, h + CAPTION_H + 2 * MARGIN), BACKGROUND)
    sheet.paste(left, (MARGIN, MARGIN))
    sheet.paste(right, (MARGIN + w + GAP, MARGIN))
    draw = ImageDraw.Draw(sheet)
    font = ImageFont.load_default(size=15)  # Pillow's own font, the same on every machine
    on = sum(1 for e in events if e[3])
    t_s = end_ns / 1e9
    captions = [
        f"{OBSERVER}'s camera during a broadcast: its RGB render at {t_s:.2f} s",
        f"its events in the {window_ms} ms to {t_s:.2f} s: "
        f"{on} ON (blue), {len(events) - on} OFF (red)",
    ]
    for k, text in enumerate(captions):
        x = MARGIN + k * (w + GAP)
        draw.text((x + 2, MARGIN + h + 5), text, fill=TEXT, font=font)
    # No metadata chunks (time, software), so the same inputs give the same bytes.
    sheet.save(out, format="PNG", optimize=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir")
    ap.add_argument("bag_dir")
    ap.add_argument("out")
    ap.add_argument("--end-s", type=float, required=True, help="end of the window, sim s")
    ap.add_argument("--window-ms", type=int, required=True, help="length of the window, ms")
    args = ap.parse_args()
    end_ns = round(args.end_s * 1000) * 1_000_000
    start_ns = end_ns - args.window_ms * 1_000_000
    render = render_at(os.path.join(args.run_dir, "session.mcap"), end_ns)
    events = events_in(args.bag_dir, start_ns, end_ns)
    if not events:
        raise SystemExit("no events in the window")
    compose(render, events, end_ns, args.window_ms, args.out)
    on = sum(1 for e in events if e[3])
    print(f"{args.out}: render at {end_ns / 1e9:.2f} s, {len(events)} events ({on} ON) "
          f"in the {args.window_ms} ms before it")


if __name__ == "__main__":
    main()
