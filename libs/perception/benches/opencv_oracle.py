"""OpenCV oracle of the RGB receiver's KLT: calcOpticalFlowPyrLK on the fixture frames and points.

A test oracle only; nothing of Waggle runs OpenCV. Run it with the pinned interpreter that
`deploy/opencv-oracle.sh` creates (third_party/opencv-oracle/venv).

    python opencv_oracle.py FIXTURE_DIR golden OUT.json
        OpenCV's forward endpoints, statuses and forward-backward verdicts for every point of
        every pair, with the settings, written as the golden file the default test compares
        our KLT with (libs/perception/tests/klt_oracle.rs).
    python opencv_oracle.py FIXTURE_DIR time [--reps N]
        Times OpenCV per frame pair on one thread (what benches/klt.rs compares ours with) and
        prints one JSON object on stdout: median and minimum over N passes of the fixture.

Settings mirror KltConfig::paper(): 21 px window, 3 pyramid levels (maxLevel 2), at most 30
iterations, epsilon 0.01 px, a minimum-eigenvalue threshold of 1e-3 (grey level / px)^2, and a
forward-backward round trip seeded at the start points (OPTFLOW_USE_INITIAL_FLOW), accepted
within 0.7 px. OpenCV's minEig is the window mean of raw Scharr products (32 x the derivative
in grey levels / px) times 2^-20, i.e. in (grey level / px)^2 / 1024, so our 1e-3 is OpenCV's
1e-3 / 1024 (its default, 1e-4, would be 0.1 (grey level / px)^2 in our unit).
"""

import json
import sys
import time
from pathlib import Path

import cv2
import numpy as np

WINDOW_PX = 21
MAX_LEVEL = 2
MAX_ITERATIONS = 30
EPSILON_PX = 0.01
MIN_EIGEN = 1e-3  # (grey level / px)^2, KltConfig::paper().min_eigen
OPENCV_MIN_EIG_THRESHOLD = MIN_EIGEN / 1024.0  # the same threshold in OpenCV's unit
FB_THRESHOLD_PX = 0.7
CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, MAX_ITERATIONS, EPSILON_PX)
WIN = (WINDOW_PX, WINDOW_PX)


def load(fixture_dir):
    fixture = json.loads((fixture_dir / "fixture.json").read_text())
    clips = []
    for clip in fixture["clips"]:
        frames = []
        for name in clip["frames"]:
            img = cv2.imread(str(fixture_dir / name), cv2.IMREAD_UNCHANGED)
            if img is None or img.ndim != 2 or img.dtype != np.uint8:
                raise SystemExit(f"{name}: not an 8-bit grey PNG")
            frames.append(img)
        as_pts = lambda v: np.array(v, np.float32).reshape(-1, 1, 2)
        pairs = [
            (p["prev"], p["next"], as_pts(p["points_px"]), as_pts(p["probes_px"]))
            for p in clip["pairs"]
        ]
        clips.append((clip["observer"], frames, pairs))
    return clips


def lk(prev, nxt, pts, guess=None):
    flags = 0 if guess is None else cv2.OPTFLOW_USE_INITIAL_FLOW
    out = None if guess is None else guess.copy()
    return cv2.calcOpticalFlowPyrLK(
        prev, nxt, pts, out, winSize=WIN, maxLevel=MAX_LEVEL, criteria=CRITERIA,
        flags=flags, minEigThreshold=OPENCV_MIN_EIG_THRESHOLD,
    )


def track_pair(prev, nxt, pts):
    """Forward endpoints and status, and the forward-backward verdict, per point."""
    fwd, st, _ = lk(prev, nxt, pts)
    back, st_b, _ = lk(nxt, prev, fwd, guess=pts)
    round_trip = np.linalg.norm((back - pts).reshape(-1, 2), axis=1)
    fb_ok = (st.ravel() == 1) & (st_b.ravel() == 1) & (round_trip <= FB_THRESHOLD_PX)
    return fwd.reshape(-1, 2), st.ravel() == 1, fb_ok


def golden(fixture_dir, out_path):
    result = {
        "opencv": cv2.__version__,
        "numpy": np.__version__,
        "settings": {
            "window_px": WINDOW_PX,
            "max_level": MAX_LEVEL,
            "max_iterations": MAX_ITERATIONS,
            "epsilon_px": EPSILON_PX,
            "min_eigen": MIN_EIGEN,
            "opencv_min_eig_threshold": OPENCV_MIN_EIG_THRESHOLD,
            "fb_threshold_px": FB_THRESHOLD_PX,
        },
        "clips": [],
    }
    for observer, frames, pairs in load(fixture_dir):
        out_pairs = []
        for prev, nxt, pts, probes in pairs:
            entry = {}
            for prefix, p in (("", pts), ("probe_", probes)):
                fwd, ok, fb_ok = track_pair(frames[prev], frames[nxt], p)
                # Forward endpoints rounded to 1e-5 px, far below any disagreement of interest.
                entry[prefix + "forward_px"] = [
                    [round(float(x), 5), round(float(y), 5)] for x, y in fwd]
                entry[prefix + "forward_ok"] = [bool(v) for v in ok]
                entry[prefix + "fb_ok"] = [bool(v) for v in fb_ok]
            out_pairs.append(entry)
        result["clips"].append({"observer": observer, "pairs": out_pairs})
    Path(out_path).write_text(json.dumps(result, separators=(",", ":")) + "\n")
    n = sum(len(p["fb_ok"]) for c in result["clips"] for p in c["pairs"])
    m = sum(len(p["probe_fb_ok"]) for c in result["clips"] for p in c["pairs"])
    print(f"wrote {out_path}: {n} points, {m} probes, OpenCV {cv2.__version__}", file=sys.stderr)


def timing(fixture_dir, reps):
    """Per frame pair, one thread. `forward_pair` is one calcOpticalFlowPyrLK call: both
    pyramids, the previous frame's derivatives and the forward pass - the work of our `prepare`
    + `track`, the like-for-like comparison. `fb_pair` adds the backward call; the Python API
    takes images only (OpenCV 5 rejects pyramid lists there), so that call builds both pyramids
    again, which our `track_fb` does not. `pyramids_pair` is the two pyramids with derivatives
    alone (buildOpticalFlowPyramid), to show how much of a call they are."""
    cv2.setNumThreads(1)
    clips = load(fixture_dir)
    # The receiver's own points only; probes are for the agreement figures.
    work = [(frames[p], frames[n], pts) for _, frames, pairs in clips for p, n, pts, _ in pairs]

    def forward_pair(prev, nxt, pts):
        lk(prev, nxt, pts)

    def fb_pair(prev, nxt, pts):
        track_pair(prev, nxt, pts)

    def pyramids_pair(prev, nxt, _pts):
        cv2.buildOpticalFlowPyramid(prev, WIN, MAX_LEVEL, withDerivatives=True)
        cv2.buildOpticalFlowPyramid(nxt, WIN, MAX_LEVEL, withDerivatives=True)

    def measure(fn):
        for args in work[:10]:
            fn(*args)
        per_pair_ms = []
        for _ in range(reps):
            start = time.perf_counter()
            for args in work:
                fn(*args)
            per_pair_ms.append((time.perf_counter() - start) * 1e3 / len(work))
        per_pair_ms.sort()
        return {"median_ms": per_pair_ms[len(per_pair_ms) // 2], "min_ms": per_pair_ms[0]}

    result = {
        "opencv": cv2.__version__,
        "threads": cv2.getNumThreads(),
        "pairs": len(work),
        "points": int(sum(len(w[2]) for w in work)),
        "forward_pair": measure(forward_pair),
        "fb_pair": measure(fb_pair),
        "pyramids_pair": measure(pyramids_pair),
    }
    print(json.dumps(result))


def main(argv):
    if len(argv) < 3 or argv[2] not in ("golden", "time"):
        raise SystemExit(__doc__)
    fixture_dir = Path(argv[1])
    if argv[2] == "golden":
        if len(argv) != 4:
            raise SystemExit("golden needs OUT.json")
        golden(fixture_dir, argv[3])
    else:
        reps = int(argv[4]) if len(argv) == 5 and argv[3] == "--reps" else 5
        timing(fixture_dir, reps)


if __name__ == "__main__":
    main(sys.argv)
