#!/usr/bin/env python3
"""Background activity of a real event sensor against illuminance, from IEBCS's measurements.

IEBCS (neuromorphicsystems/IEBCS, the ICNS event-based camera simulator) ships the background
activity it measured on a real sensor in three lights as per-pixel distributions:
``data/noise_{pos,neg}_{0.1lux,161lux,3klux}.npy``, each a 50 x 50 array of pixels by 72
frequency bins. Read the way IEBCS's own ``DvsSensor.init_bgn_hist`` and ``get_next_noise``
read them, each pixel's row is a cumulative count of its noise events over the bins
``FREQ = [1, 2, ..., 9] x 10^k Hz, k = -3 ... 4``: an event in bin f is followed by the next
after 1/f seconds. A pixel's rate is therefore its count over the sum of its intervals,
``n / sum(dn_f / f)``, and a pixel with no event has rate 0.

This script prints, per light and polarity, the mean rate over the array (Hz per pixel), the
share of pixels with any event, and the shot-noise law Waggle derives from them (shot noise is
fair in polarity, so twice the OFF rate; ON events beyond it are leak).

Usage::

    python iebcs_background.py --iebcs /path/to/IEBCS-checkout

The files are checked against the SHA-256 digests below before they are read; the figures go
into libs/perturb/src/light.rs, the files stay out of the repository.
"""

import argparse
import hashlib
import json
import math
import pathlib
import sys

import numpy as np

LIGHTS = (("0.1lux", 0.1), ("161lux", 161.0), ("3klux", 3000.0))
SHA256 = {
    "noise_pos_0.1lux.npy": "ec54ba87b1f8ca3804b649f74cac0307150ce5e54fba880db0deed6201fc4b1c",
    "noise_neg_0.1lux.npy": "df41bed55bc6090859560cfad9de8e219118d2df677348ca891f5fa09a621940",
    "noise_pos_161lux.npy": "98830f6cda16267fb2555eaaefc6b2094b18a183eb4a8dc4d0077d8b86a4d88d",
    "noise_neg_161lux.npy": "13311fc94aaaeecd64a39d88825dfb711a93beb44b6f59eabc70a3579d55acd0",
    "noise_pos_3klux.npy": "7a702eafc3165d6874e44a88531988cd2eca68cd438d6c0700fbc553c6f428af",
    "noise_neg_3klux.npy": "9f12adf5aad1aad4bfd7afd55471eb255e5edd5b868e2ef9e6c5ff09163daf52",
}
FREQ_HZ = np.array([m * 10.0**k for k in range(-3, 5) for m in range(1, 10)])


def pixel_rates_hz(path: pathlib.Path) -> np.ndarray:
    cumulative = np.load(path).reshape(-1, FREQ_HZ.size).astype(float)
    # IEBCS's rows end in a 0 column (its normaliser is the second-to-last column).
    cumulative = cumulative[:, :-1]
    per_bin = np.diff(cumulative, axis=1, prepend=0.0)
    if (per_bin < 0).any():
        sys.exit(f"{path}: a row is not cumulative")
    events = cumulative[:, -1]
    seconds = (per_bin / FREQ_HZ[:-1]).sum(axis=1)
    return np.where(events > 0, events / np.where(seconds > 0, seconds, 1.0), 0.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--iebcs", required=True, type=pathlib.Path, help="an IEBCS checkout")
    data = parser.parse_args().iebcs / "data"
    for name, digest in SHA256.items():
        got = hashlib.sha256((data / name).read_bytes()).hexdigest()
        if got != digest:
            sys.exit(f"{data / name}: sha256 {got}, expected {digest}")
    rows = []
    for tag, lux in LIGHTS:
        row = {"lux": lux}
        for polarity in ("pos", "neg"):
            rates = pixel_rates_hz(data / f"noise_{polarity}_{tag}.npy")
            key = "on" if polarity == "pos" else "off"
            row[f"{key}_hz"] = round(float(rates.mean()), 6)
            row[f"{key}_active"] = round(float((rates > 0).mean()), 4)
        rows.append(row)
    dim, mid = rows[0], rows[1]
    exponent = math.log(dim["off_hz"] / mid["off_hz"]) / math.log(mid["lux"] / dim["lux"])
    print(
        json.dumps(
            {
                "source": "neuromorphicsystems/IEBCS data/noise_{pos,neg}_*.npy",
                "lights": rows,
                "shot_noise": {
                    "hz_at_dim": round(2.0 * dim["off_hz"], 6),
                    "dim_lux": dim["lux"],
                    "exponent": round(exponent, 4),
                },
            },
            indent=2,
        )
    )


if __name__ == "__main__":
    main()
