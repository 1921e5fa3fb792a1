"""Composes docs/images/bit0-onset.png: the packets around a `BIT0`'s first motion on both
renderers, the events in the event tracker's window, each panel captioned with what the tracker
saw there after the noise front end (ON and OFF counts) and what it decided.

    make_onset.py DIR END_NS OUT.png

DIR holds, per renderer (`raster`, `damage`), `RENDER.packets.csv` (the `event_symbols`
example's per-packet verdicts) and `RENDER.events.csv` (`t_ns,x,y,on` of the raw events).
END_NS is the end of the packet where Waggle's renderer's track was put in doubt (or
interrupted) by a one-sided window. Run by
make-onset.sh, which fixes the seed and sensor terms.
"""

import argparse
import csv
import os

import numpy as np
from PIL import Image, ImageDraw, ImageFont

PACKET_NS = 40_000_000
HALF_W, HALF_H = 64, 48  # the tracker's local window (EventTrackerConfig::paper)
ONE_SIDED = 0.9  # its one_sided_fraction
SCALE = 3
GAP, MARGIN, CAPTION_H, TITLE_W = 12, 12, 58, 150
BACKGROUND = (255, 255, 255)
EVENT_BACKGROUND = (16, 18, 24)
ON_COLOUR = (90, 180, 255)
OFF_COLOUR = (255, 96, 64)
TEXT = (30, 30, 30)
RENDERERS = [("raster", "Waggle's\nrenderer"), ("damage", "MuJoCo's\nrenderer")]
LEGEND = "events of the packet\nin the tracker's\nwindow, 128 x 96 px:\nON blue, OFF red"


def read_packets(path):
    with open(path, newline="") as f:
        return {int(r["end_ns"]): r for r in csv.DictReader(f)}


def read_events(path):
    with open(path, newline="") as f:
        return [(int(r["t_ns"]), int(r["x"]), int(r["y"]), r["on"] == "1") for r in csv.DictReader(f)]


def verdict(row):
    if row["interruption"]:
        fault = row["fault"]
        if "majority_fraction: " in fault:
            share = float(fault.split("majority_fraction: ")[1].split(",")[0])
            return f"interrupted: the confirming window {share:.1%} one polarity"
        return f"interrupted: {row['interruption']}"
    if row.get("doubt_share"):
        share = float(row["doubt_share"])
        return f"doubted: the confirming window {share:.1%} one polarity; held"
    if row["window_on"] == "":
        return "no estimate"
    on, off = int(row["window_on"]), int(row["window_off"])
    if on + off and max(on, off) / (on + off) >= ONE_SIDED:
        return "one-sided: held, the next packet confirms"
    return "located"


def panel(events, centre, end_ns):
    cx, cy = round(centre[0]), round(centre[1])
    img = np.empty((2 * HALF_H, 2 * HALF_W, 3), dtype=np.uint8)
    img[:] = EVENT_BACKGROUND
    for t, x, y, on in events:  # in time order: a pixel shows its last event
        if end_ns - PACKET_NS < t <= end_ns and abs(x - cx) < HALF_W and abs(y - cy) < HALF_H:
            img[y - cy + HALF_H, x - cx + HALF_W] = ON_COLOUR if on else OFF_COLOUR
    crop = Image.fromarray(img)
    return crop.resize((2 * HALF_W * SCALE, 2 * HALF_H * SCALE), Image.Resampling.NEAREST)


def caption(row, end_ns):
    on, off = row["window_on"], row["window_off"]
    counts = f"{on} ON, {off} OFF" if on != "" else "(confirming the packet before)"
    share = ""
    if on != "" and int(on) + int(off):
        share = f" ({max(int(on), int(off)) / (int(on) + int(off)):.1%} one polarity)"
    return [f"packet to {end_ns / 1e9:.2f} s", f"after the front end: {counts}{share}",
            verdict(row)]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir")
    ap.add_argument("end_ns", type=int)
    ap.add_argument("out")
    args = ap.parse_args()
    ends = [args.end_ns - PACKET_NS, args.end_ns, args.end_ns + PACKET_NS]
    w, h = 2 * HALF_W * SCALE, 2 * HALF_H * SCALE
    sheet = Image.new("RGB", (TITLE_W + 3 * w + 2 * GAP + 2 * MARGIN,
                              2 * (h + CAPTION_H) + GAP + 2 * MARGIN), BACKGROUND)
    draw = ImageDraw.Draw(sheet)
    font = ImageFont.load_default(size=14)  # Pillow's own font, the same on every machine
    for r, (render, title) in enumerate(RENDERERS):
        packets = read_packets(os.path.join(args.dir, f"{render}.packets.csv"))
        events = read_events(os.path.join(args.dir, f"{render}.events.csv"))
        y0 = MARGIN + r * (h + CAPTION_H + GAP)
        draw.multiline_text((MARGIN, y0 + h // 2 - 20), title, fill=TEXT, font=font)
        if r == 0:
            draw.multiline_text((MARGIN, y0), LEGEND, fill=TEXT, font=font)
        for k, end_ns in enumerate(ends):
            # The window is where the tracker looked: around the estimate it held before.
            before = packets[end_ns - PACKET_NS]
            centre = (float(before["x_px"] or 320), float(before["y_px"] or 240))
            x0 = MARGIN + TITLE_W + k * (w + GAP)
            sheet.paste(panel(events, centre, end_ns), (x0, y0))
            for line, text in enumerate(caption(packets[end_ns], end_ns)):
                draw.text((x0 + 2, y0 + h + 4 + 17 * line), text, fill=TEXT, font=font)
    # No metadata chunks (time, software), so the same inputs give the same bytes.
    sheet.save(args.out, format="PNG", optimize=True)
    print(f"{args.out}: packets ending {', '.join(f'{e / 1e9:.2f}' for e in ends)} s")


if __name__ == "__main__":
    main()
