"""The maps of one `benches/gpu_lease.sh run` call held against each other (issue 58's
agreement targets), from the folder its tarball unpacks into (or `unpack`'s docs/bench/gpu/<adapter>/).

Usage: python benches/kernels_agree.py DIR > DIR/AGREEMENT.md   (needs numpy)

Pairs, where both maps came back (a map cut by its time limit has no map.json):
- parity_gpu / parity_cpu: the GPU engine (f32) against the CPU engine (f64), N = 3;
- OLD / NEW, given as `kernels_agree.py DIR OLD NEW`: two maps of the same scene by two builds
  (issue 73: the hand-written kernels against the generated ones).
For each: the cells; the same K class (K > 0.5 chaotic) on how many; the same period on how many
of the cells periodic in both (period > 0); the same regime, where both have one; each map's wall
time (map.json's timings_s.total_s). The kernels' targets: K class >= 99 %, period >= 98 %.
"""
import json
import os
import sys

import numpy as np

PAIRS = (("parity_gpu", "parity_cpu", "GPU f32 against CPU f64, N = 3"),)


def load(folder):
    """map.json and the arrays of a map folder, or None where it did not come back."""
    path = os.path.join(folder, "map.json")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        meta = json.load(f)
    arrays = {}
    for key in ("K", "period", "regime"):
        npy = os.path.join(folder, f"{key}.npy")
        if os.path.exists(npy):
            arrays[key] = np.load(npy)
    return meta, arrays


def share(mask):
    """'a of b (p %)' of a boolean array; '–' when it is empty."""
    if mask.size == 0:
        return "–"
    return f"{int(mask.sum())} of {mask.size} ({100 * mask.mean():.1f} %)"


def row(a, b):
    """The table row's agreement cells of maps a and b."""
    (ma, xa), (mb, xb) = a, b
    k = (xa["K"] > 0.5) == (xb["K"] > 0.5) if "K" in xa and "K" in xb else np.array([])
    if "period" in xa and "period" in xb:
        both = (xa["period"] > 0) & (xb["period"] > 0)
        p = xa["period"][both] == xb["period"][both]
    else:
        p = np.array([])
    r = xa["regime"] == xb["regime"] if "regime" in xa and "regime" in xb else np.array([])
    walls = f"{ma['timings_s']['total_s']:.1f} / {mb['timings_s']['total_s']:.1f}"
    return [str(ma["instances"]), share(k), share(p), share(r), walls]


def report(root, pairs=PAIRS):
    """The report's lines for the lease folder `root`."""
    lines = [
        "# The lease's maps held against each other",
        "",
        "Written by `benches/kernels_agree.py` from one `benches/gpu_lease.sh run` call.",
        "",
        "| pair | cells | same K class | same period (periodic in both) | same regime | wall (s) |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for left, right, label in pairs:
        a, b = load(os.path.join(root, left)), load(os.path.join(root, right))
        if a is None or b is None:
            missing = ", ".join(n for n, m in ((left, a), (right, b)) if m is None)
            lines.append(f"| {label} | not brought back: {missing} | | | | |")
            continue
        shapes = {tuple(x.shape) for m in (a, b) for x in m[1].values()}
        if len(shapes) > 1:
            lines.append(f"| {label} | different grids: {sorted(shapes)} | | | | |")
            continue
        lines.append("| " + " | ".join([label] + row(a, b)) + " |")
    return lines


if __name__ == "__main__":
    if len(sys.argv) not in (2, 4) or not os.path.isdir(sys.argv[1]):
        sys.exit(
            "usage: python benches/kernels_agree.py DIR [OLD NEW] (the folder a lease call "
            "unpacks into; OLD and NEW: two map folders under it to hold against each other)"
        )
    pairs = PAIRS if len(sys.argv) == 2 else ((sys.argv[2], sys.argv[3], f"{sys.argv[2]} / {sys.argv[3]}"),)
    print("\n".join(report(sys.argv[1], pairs)))
