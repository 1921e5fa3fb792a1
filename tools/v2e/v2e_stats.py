#!/usr/bin/env python3
"""Measure v2e's DVS model on synthetic scenes, to validate Waggle's event-camera noise model.

Runs the reference emulator of v2e (SensorsINI/v2e, ``v2ecore.emulator.EventEmulator``) on
CPU, on frame sequences generated here, for three parameter sets and writes one JSON per set:

* ``clean``   -- ``v2e --dvs_params clean``  (EventEmulator.set_dvs_params('clean'));
* ``default`` -- ``v2e`` without ``--dvs_params``: the command-line defaults of v2e_args.py
  (pos/neg 0.2, sigma 0.03, cutoff 300 Hz, leak 0.01 Hz, shot 0.001 Hz, refractory 0.5 ms, ...);
* ``noisy``   -- ``v2e --dvs_params noisy``.

The emulator is built exactly as v2e.py does it: ``EventEmulator(<command-line defaults>)``,
then ``set_dvs_params(preset)`` for clean/noisy. Variants override single attributes afterwards
(before the first frame, so the per-pixel arrays drawn at the first frame follow them).
v2e's optional output/GUI modules (h5py, screeninfo, dv_processing, easygui, ...) are replaced
by empty stand-ins, so only numpy, torch and opencv are needed.

Usage::

    python v2e_stats.py --v2e /path/to/v2e-checkout --out DIR [--v2e-commit SHA]

Everything is deterministic: seed SEED for every run (v2e seeds torch, numpy and random with
it), torch on one CPU thread. Results depend on the torch version (recorded in the JSON).

Frames (reproduce them exactly to feed the same input to another emulator)
-------------------------------------------------------------------------
Image WIDTH x HEIGHT = 64 x 48 pixels, x = column 0..63, y = row 0..47. Each frame is a grey
level ``g(x, y)``, an integer 0..255 (uint8); v2e receives it as a [48, 64] uint8 array (row y,
column x). An RGB renderer gets R = G = B = g, whose luminance 0.299R + 0.587G + 0.114B is g
exactly. Frame k (k = 0, 1, ..., N-1) has time ``t_k = k / fps`` seconds (f64 division).
The first frame (k = 0) only initialises the emulator.

(a) Static scene, fps = 100, N = STATIC_SECONDS[preset] * 100 + 1 frames, every frame equal::

        g(x, y) = STATIC_LEVELS[(x // 8 + y // 8) % 8]
        STATIC_LEVELS = (2, 5, 10, 20, 40, 80, 160, 250)

    i.e. 8x8 blocks in diagonal stripes; each level covers 6 blocks = 384 pixels.
    "dark" pixels: level <= 20 (v2e's linear lin_log range); "bright": level >= 40.

(b) Moving step edge and moving bar, dark = 20, bright = 200, fps = 100 and fps = 1000.
(c) The same dimmed x0.1: dark = 2, bright = 20 (so the photoreceptor cutoff matters).

    Edge: vertical at column position ``e(t)`` (pixels, f64); left of it is bright::

        V = 32.0 px/s, T0 = 0.25 s, SWEEP = 64 / V = 2.0 s, HOLD = 1.0 s,
        T1 = T0 + SWEEP + HOLD = 3.25 s, DURATION = T1 + SWEEP + HOLD = 6.25 s
        e(t) = 0                     for t < T0
             = V * (t - T0)          for T0 <= t < T0 + SWEEP      (sweep right: ON)
             = 64                    for T0 + SWEEP <= t < T1
             = 64 - V * (t - T1)     for T1 <= t < T1 + SWEEP      (sweep back: OFF)
             = 0                     for t >= T1 + SWEEP
        c(x, t) = min(max(e(t) - x, 0), 1)        (bright fraction of pixel [x, x+1])
        g(x, y, t) = floor(dark + (bright - dark) * c(x, t) + 0.5)   (f64, this order)

    N = DURATION * fps + 1 frames (626 at 100 Hz, 6251 at 1 kHz). Rows are identical.
    Pixel column x is half covered (the "true crossing") at
    ``t_on(x) = T0 + (x + 0.5) / V`` on the right sweep (dark -> bright, ON events) and
    ``t_off(x) = T1 + (64 - x - 0.5) / V`` on the way back (bright -> dark, OFF events).

    Bar: a bright bar of width B = 2 px moving right once over the dark background, so each
    pixel is bright for only B / V = 62.5 ms (a low-pass filter can lose events here, while a
    held step edge always catches up)::

        b(t) = 0 for t < T0, else V * (t - T0)        (leading edge; no upper clamp)
        c(x, t) = min(max(b(t) - x, 0), 1) - min(max((b(t) - B) - x, 0), 1)
        g(x, y, t) = floor(dark + (bright - dark) * c(x, t) + 0.5)

    BAR_DURATION = 3.5 s, N = 3.5 * fps + 1 frames. Crossings: leading edge (ON) at
    ``T0 + (x + 0.5) / V``, trailing edge (OFF) at ``T0 + (x + 0.5 + B) / V``.

    No grey value of (b) or (c) lies within 0.003 of a rounding tie (dark + (bright - dark) * c
    is never within 0.003 of n + 0.5), so an f64 evaluation that differs in the last bit gives
    the same frames.

    Events of a pixel with t in [t_c - 0.1 s, t_c + 0.6 s) and the crossing's polarity belong
    to that crossing (for the bar both windows overlap; polarity separates them).

Variants
--------
static: ``preset`` (as is), ``shot_only`` (leak_rate_hz = 0), ``leak_only``
(shot_noise_rate_hz = 0).
edge and bar: ``signal`` (shot_noise_rate_hz = 0, leak_rate_hz = 0), ``signal_no_cutoff`` (also
cutoff_hz = 0), ``preset`` (everything on; its window counts include noise events).

Output (DIR/v2e_<preset>.json)
------------------------------
``v2e`` (repository, commit, torch/numpy versions), ``preset``, ``seed``, ``params`` (the
emulator's values after set_dvs_params), ``frames`` (the constants above), ``static``
(per variant: overrides, params, rates overall / ON / OFF / per level / dark / bright,
per-pixel rate spread, first-event time, steady-state rate), ``moving`` (one run per shape x
fps x brightness x variant: per crossing the events per pixel and the lag statistics,
lag = event time - true crossing time, in seconds), and ``summary`` (the headline numbers:
events per pixel and median lags with and without the cutoff, and the count loss
1 - events(cutoff) / events(no cutoff)).
"""

import argparse
import json
import logging
import os
import subprocess
import sys
import types

import numpy as np

SEED = 1
WIDTH, HEIGHT = 64, 48

STATIC_FPS = 100
STATIC_LEVELS = (2, 5, 10, 20, 40, 80, 160, 250)
STATIC_BLOCK = 8
DARK_MAX_LEVEL = 20  # v2e's lin_log is linear up to 20 DN
# Long enough for several leak periods (v2e starts leaking from phase 0, see the notes).
STATIC_SECONDS = {"clean": 10, "default": 300, "noisy": 100}

EDGE_FPS = (100, 1000)
EDGE_BRIGHTNESS = {"bright": (20, 200), "dim": (2, 20)}  # (dark, bright) grey levels
EDGE_V = 32.0
EDGE_T0 = 0.25
EDGE_SWEEP = WIDTH / EDGE_V
EDGE_HOLD = 1.0
EDGE_T1 = EDGE_T0 + EDGE_SWEEP + EDGE_HOLD
EDGE_DURATION = EDGE_T1 + EDGE_SWEEP + EDGE_HOLD
EDGE_WINDOW = (-0.1, 0.6)  # seconds around the true crossing
BAR_WIDTH = 2.0
BAR_DURATION = 3.5
SHAPES = ("edge", "bar")

# v2e.py without --dvs_params: the command-line defaults of v2ecore/v2e_args.py, passed to
# EventEmulator the way v2e.py passes them.
V2E_CLI_DEFAULTS = dict(
    pos_thres=0.2,
    neg_thres=0.2,
    sigma_thres=0.03,
    cutoff_hz=300.0,
    leak_rate_hz=0.01,
    shot_noise_rate_hz=0.001,
    photoreceptor_noise=False,
    leak_jitter_fraction=0.1,
    noise_rate_cov_decades=0.1,
    refractory_period_s=0.0005,
)
PRESETS = ("clean", "default", "noisy")
PARAM_NAMES = tuple(V2E_CLI_DEFAULTS) + ("pos_thres_nominal", "neg_thres_nominal",
                                         "SHOT_NOISE_INTEN_FACTOR")


# ---------------------------------------------------------------------------------------------
# v2e


def load_event_emulator(v2e_path):
    """Imports v2ecore.emulator.EventEmulator from the checkout, with stand-ins for the modules
    it imports only for file output, screen placement and the GUI."""

    def stand_in(name, **attrs):
        module = types.ModuleType(name)
        module.__dict__.update(attrs)
        sys.modules.setdefault(name, module)

    def v2e_quit(code=0):
        raise SystemExit(code)

    stand_in("h5py")
    stand_in("screeninfo", get_monitors=lambda: [])
    stand_in("v2ecore.output")
    stand_in("v2ecore.output.ae_text_output", DVSTextOutput=None)
    stand_in("v2ecore.output.aedat2_output", AEDat2Output=None)
    stand_in("v2ecore.output.aedat4_output", AEDat4Output=None)
    stand_in("v2ecore.v2e_utils", checkAddSuffix=None, v2e_quit=v2e_quit, video_writer=None)
    sys.path.insert(0, os.path.abspath(v2e_path))
    from v2ecore.emulator import EventEmulator  # found through the path above

    return EventEmulator


def v2e_commit(v2e_path, given):
    if given:
        return given
    try:
        out = subprocess.run(["git", "-C", v2e_path, "rev-parse", "HEAD"], check=True,
                             capture_output=True, text=True)
        return out.stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        sys.exit("cannot tell the v2e commit (no git work tree): pass --v2e-commit SHA")


def make_emulator(EventEmulator, preset, overrides):
    emulator = EventEmulator(**V2E_CLI_DEFAULTS, seed=SEED, device="cpu")
    if preset != "default":
        emulator.set_dvs_params(preset)
    for name, value in overrides.items():
        setattr(emulator, name, value)
    params = {name: getattr(emulator, name) for name in PARAM_NAMES}
    return emulator, params


def run(emulator, frames, fps):
    """Feeds frame k at t = k / fps; returns the events as columns t (s), x, y, on (bool)."""
    chunks = []
    for k, frame in enumerate(frames):
        events = emulator.generate_events(frame, k / fps)
        if events is not None:
            chunks.append(np.asarray(events, dtype=np.float64))
    events = np.concatenate(chunks) if chunks else np.zeros((0, 4))
    return {"t": events[:, 0], "x": events[:, 1].astype(np.int64),
            "y": events[:, 2].astype(np.int64), "on": events[:, 3] > 0}


# ---------------------------------------------------------------------------------------------
# Frames (documented in the module docstring)


def static_frame():
    y, x = np.mgrid[0:HEIGHT, 0:WIDTH]
    levels = np.array(STATIC_LEVELS, dtype=np.uint8)
    return levels[(x // STATIC_BLOCK + y // STATIC_BLOCK) % len(STATIC_LEVELS)]


def edge_position(t):
    if t < EDGE_T0:
        return 0.0
    if t < EDGE_T0 + EDGE_SWEEP:
        return EDGE_V * (t - EDGE_T0)
    if t < EDGE_T1:
        return float(WIDTH)
    if t < EDGE_T1 + EDGE_SWEEP:
        return WIDTH - EDGE_V * (t - EDGE_T1)
    return 0.0


def bar_position(t):
    return 0.0 if t < EDGE_T0 else EDGE_V * (t - EDGE_T0)


def coverage(e, x):
    """Fraction of pixel [x, x + 1] left of position e."""
    return np.minimum(np.maximum(e - x, 0.0), 1.0)


def moving_frames(shape, fps, dark, bright):
    x = np.arange(WIDTH, dtype=np.float64)
    duration = EDGE_DURATION if shape == "edge" else BAR_DURATION
    for k in range(round(duration * fps) + 1):
        t = k / fps
        if shape == "edge":
            c = coverage(edge_position(t), x)
        else:
            b = bar_position(t)
            c = coverage(b, x) - coverage(b - BAR_WIDTH, x)
        row = np.floor(dark + (bright - dark) * c + 0.5).astype(np.uint8)
        yield np.repeat(row[None, :], HEIGHT, axis=0)


def crossings(shape):
    """[(name, true crossing time of each column, ON polarity?)] of a moving shape."""
    x = np.arange(WIDTH, dtype=np.float64)
    if shape == "edge":
        return [("on_sweep", EDGE_T0 + (x + 0.5) / EDGE_V, True),
                ("off_sweep", EDGE_T1 + (WIDTH - x - 0.5) / EDGE_V, False)]
    return [("leading", EDGE_T0 + (x + 0.5) / EDGE_V, True),
            ("trailing", EDGE_T0 + (x + 0.5 + BAR_WIDTH) / EDGE_V, False)]


# ---------------------------------------------------------------------------------------------
# Statistics


def quantiles(values, qs=(10, 50, 90)):
    values = np.asarray(values, dtype=np.float64)
    if values.size == 0:
        return None
    out = {"mean": float(values.mean()), "std": float(values.std()),
           "min": float(values.min()), "max": float(values.max())}
    for q in qs:
        out[f"p{q}"] = float(np.percentile(values, q))
    return out


def static_stats(ev, duration, level_map, params):
    pixels = WIDTH * HEIGHT
    index = ev["y"] * WIDTH + ev["x"]
    per_pixel = np.bincount(index, minlength=pixels)
    on_pp = np.bincount(index[ev["on"]], minlength=pixels)
    off_pp = per_pixel - on_pp
    levels = level_map.ravel()

    def rates(mask):
        n = int(mask.sum())
        return {"pixels": n,
                "rate_on_hz": float(on_pp[mask].sum() / (n * duration)),
                "rate_off_hz": float(off_pp[mask].sum() / (n * duration))}

    # v2e's shot-noise rate formula (emulator_utils.generate_shot_noise), without the
    # per-pixel threshold factor nominal/actual and the at-most-one-event-per-frame cap.
    factor = params["SHOT_NOISE_INTEN_FACTOR"]
    by_level = []
    for level in STATIC_LEVELS:
        entry = {"level": level, **rates(levels == level)}
        inten01 = (level + 20) / 275
        entry["formula_shot_rate_hz"] = params["shot_noise_rate_hz"] * ((factor - 1) * inten01 + 1)
        by_level.append(entry)

    first = np.full(pixels, np.inf)
    last = np.full(pixels, -np.inf)
    np.minimum.at(first, index, ev["t"])
    np.maximum.at(last, index, ev["t"])
    many = (per_pixel >= 2) & (last > first)
    steady = (per_pixel[many] - 1) / (last[many] - first[many])

    return {
        "events_on": int(ev["on"].sum()),
        "events_off": int((~ev["on"]).sum()),
        "rate_hz_per_pixel": {"all": float(per_pixel.sum() / (pixels * duration)),
                              "on": float(on_pp.sum() / (pixels * duration)),
                              "off": float(off_pp.sum() / (pixels * duration))},
        "dark": rates(levels <= DARK_MAX_LEVEL),
        "bright": rates(levels > DARK_MAX_LEVEL),
        "by_level": by_level,
        "per_pixel_rate_hz": quantiles(per_pixel / duration),
        "pixels_with_events": int((per_pixel > 0).sum()),
        "first_event_s": quantiles(first[per_pixel > 0]),
        "steady_rate_hz": quantiles(steady),  # (n - 1) / (t_last - t_first), pixels with n >= 2
    }


def crossing_stats(ev, t_cross_of_x, on):
    """Events of each pixel within EDGE_WINDOW of its crossing; `on`: the expected polarity."""
    pixels = WIDTH * HEIGHT
    lag = ev["t"] - t_cross_of_x[ev["x"]]
    inside = (lag >= EDGE_WINDOW[0]) & (lag < EDGE_WINDOW[1])
    right = inside & (ev["on"] == on)
    wrong = inside & (ev["on"] != on)
    index = ev["y"] * WIDTH + ev["x"]
    counts = np.bincount(index[right], minlength=pixels)
    first = np.full(pixels, np.inf)
    last = np.full(pixels, -np.inf)
    np.minimum.at(first, index[right], lag[right])
    np.maximum.at(last, index[right], lag[right])
    has = counts > 0
    hist = np.bincount(counts)
    return {
        "events_per_pixel": quantiles(counts),
        "events_per_pixel_histogram": {str(n): int(c) for n, c in enumerate(hist) if c},
        "opposite_polarity_per_pixel": float(np.bincount(index[wrong], minlength=pixels).mean()),
        "lag_first_event_s": quantiles(first[has]),
        "lag_last_event_s": quantiles(last[has]),
        "lag_all_events_s": quantiles(lag[right]),
    }


# ---------------------------------------------------------------------------------------------
# Scenarios


def static_scenario(EventEmulator, preset):
    seconds = STATIC_SECONDS[preset]
    frame = static_frame()
    n = seconds * STATIC_FPS + 1
    variants = {"preset": {}, "shot_only": {"leak_rate_hz": 0.0},
                "leak_only": {"shot_noise_rate_hz": 0.0}}
    out = {"fps": STATIC_FPS, "frames": n, "duration_s": (n - 1) / STATIC_FPS, "variants": {}}
    for name, overrides in variants.items():
        emulator, params = make_emulator(EventEmulator, preset, overrides)
        ev = run(emulator, (frame for _ in range(n)), STATIC_FPS)
        out["variants"][name] = {"overrides": overrides, "params": params,
                                 "stats": static_stats(ev, out["duration_s"], frame, params)}
        logging.info("%s static %s: %d events", preset, name, len(ev["t"]))
    return out


def moving_scenario(EventEmulator, preset):
    variants = {"signal": {"shot_noise_rate_hz": 0.0, "leak_rate_hz": 0.0},
                "signal_no_cutoff": {"shot_noise_rate_hz": 0.0, "leak_rate_hz": 0.0,
                                     "cutoff_hz": 0.0},
                "preset": {}}
    runs = []
    for shape in SHAPES:
        for fps in EDGE_FPS:
            for brightness, (dark, bright) in EDGE_BRIGHTNESS.items():
                for name, overrides in variants.items():
                    emulator, params = make_emulator(EventEmulator, preset, overrides)
                    ev = run(emulator, moving_frames(shape, fps, dark, bright), fps)
                    entry = {"shape": shape, "fps": fps, "brightness": brightness,
                             "dark": dark, "bright": bright, "variant": name,
                             "overrides": overrides, "params": params}
                    for crossing, t_cross, on in crossings(shape):
                        entry[crossing] = crossing_stats(ev, t_cross, on)
                    runs.append(entry)
                    logging.info("%s %s %d Hz %s %s: %d events", preset, shape, fps,
                                 brightness, name, len(ev["t"]))
    return {"runs": runs}


def summarise(static, moving_runs):
    summary = {"static_rate_hz_per_pixel": {
        name: {"all": v["stats"]["rate_hz_per_pixel"]["all"],
               "dark": v["stats"]["dark"]["rate_on_hz"] + v["stats"]["dark"]["rate_off_hz"],
               "bright": v["stats"]["bright"]["rate_on_hz"] + v["stats"]["bright"]["rate_off_hz"]}
        for name, v in static["variants"].items()}}

    def median(stats):
        return None if stats is None else stats["p50"]

    by_key = {(r["shape"], r["fps"], r["brightness"], r["variant"]): r for r in moving_runs["runs"]}
    moving = {}
    for shape in SHAPES:
        for fps in EDGE_FPS:
            for brightness in EDGE_BRIGHTNESS:
                sig = by_key[(shape, fps, brightness, "signal")]
                ref = by_key[(shape, fps, brightness, "signal_no_cutoff")]
                entry = {}
                for crossing, _, _ in crossings(shape):
                    s, r = sig[crossing], ref[crossing]
                    n_sig = s["events_per_pixel"]["mean"]
                    n_ref = r["events_per_pixel"]["mean"]
                    entry[crossing] = {
                        "events_per_pixel": n_sig,
                        "events_per_pixel_no_cutoff": n_ref,
                        "count_loss_from_cutoff": 1 - n_sig / n_ref if n_ref else None,
                    }
                    for lag in ("first", "last", "all"):
                        key = f"lag_{lag}_event{'s' if lag == 'all' else ''}_s"
                        entry[crossing][f"median_lag_{lag}_s"] = median(s[key])
                        entry[crossing][f"median_lag_{lag}_no_cutoff_s"] = median(r[key])
                moving[f"{shape}_{brightness}_{fps}hz"] = entry
    summary["moving"] = moving
    return summary


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--v2e", required=True, help="path of a v2e source checkout")
    parser.add_argument("--out", required=True, help="output folder for v2e_<preset>.json")
    parser.add_argument("--v2e-commit", help="v2e commit, if --v2e is not a git work tree")
    parser.add_argument("--presets", nargs="+", default=list(PRESETS), choices=PRESETS)
    args = parser.parse_args()

    logging.basicConfig(level=logging.INFO, format="%(message)s")
    logging.getLogger("v2ecore").setLevel(logging.ERROR)  # per-frame "no events" warnings
    import torch

    torch.set_num_threads(1)
    EventEmulator = load_event_emulator(args.v2e)
    commit = v2e_commit(args.v2e, args.v2e_commit)
    os.makedirs(args.out, exist_ok=True)

    frames_doc = {
        "width": WIDTH, "height": HEIGHT,
        "static": {"fps": STATIC_FPS, "levels": STATIC_LEVELS, "block": STATIC_BLOCK,
                   "rule": "g = levels[(x // block + y // block) % 8]",
                   "seconds": STATIC_SECONDS, "dark_max_level": DARK_MAX_LEVEL},
        "edge": {"fps": EDGE_FPS, "brightness": EDGE_BRIGHTNESS, "v_px_per_s": EDGE_V,
                 "t0_s": EDGE_T0, "sweep_s": EDGE_SWEEP, "hold_s": EDGE_HOLD, "t1_s": EDGE_T1,
                 "duration_s": EDGE_DURATION, "window_s": EDGE_WINDOW,
                 "rule": "g = floor(dark + (bright - dark) * clamp(e(t) - x, 0, 1) + 0.5)"},
        "bar": {"width_px": BAR_WIDTH, "duration_s": BAR_DURATION,
                "rule": "g = floor(dark + (bright - dark) * (clamp(b(t) - x, 0, 1)"
                        " - clamp((b(t) - width) - x, 0, 1)) + 0.5), b(t) = v * max(t - t0, 0)"},
    }
    for preset in args.presets:
        static = static_scenario(EventEmulator, preset)
        moving = moving_scenario(EventEmulator, preset)
        _, params = make_emulator(EventEmulator, preset, {})
        result = {
            "generator": "tools/v2e/v2e_stats.py",
            "v2e": {"repository": "SensorsINI/v2e", "commit": commit,
                    "torch": torch.__version__, "numpy": np.__version__},
            "preset": preset,
            "seed": SEED,
            "params": params,
            "frames": frames_doc,
            "summary": summarise(static, moving),
            "static": static,
            "moving": moving,
        }
        path = os.path.join(args.out, f"v2e_{preset}.json")
        with open(path, "w") as f:
            json.dump(result, f, indent=1, allow_nan=False)
            f.write("\n")
        logging.info("wrote %s", path)


if __name__ == "__main__":
    main()
