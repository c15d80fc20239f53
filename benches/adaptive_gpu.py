"""Fixed against adaptive steps on the GPU engine (issue 43): the report of one
`benches/gpu_lease.sh adaptive` call, from the folder its tarball unpacks into.

Usage: python benches/adaptive_gpu.py DIR > DIR/ADAPTIVE.md   (needs numpy)

DIR holds one folder per map (n3_fixed, n3_adaptive, n3_tight, sub17_*, full17_adaptive,
full9_adaptive) with its map.json and .npy files, and adaptive.txt (each map's wall time
and exit code as the script saw it). A map cut by its time limit has no map.json and is
reported with that limit as a lower bound.
"""
import json
import os
import sys

import numpy as np

DIR = sys.argv[1]


def load(name):
    path = os.path.join(DIR, name, "map.json")
    if not os.path.exists(path):
        return None
    j = json.load(open(path))
    arrays = {}
    for k in ("K", "period"):
        f = os.path.join(DIR, name, f"{k}.npy")
        if os.path.exists(f):
            arrays[k] = np.load(f)
    return j, arrays


def limits():
    """name -> (seconds, rc, limit) from adaptive.txt."""
    out = {}
    for line in open(os.path.join(DIR, "adaptive.txt")):
        name, rest = line.split(":", 1)
        secs = int(rest.split()[0])
        rc = int(rest.split("rc ")[1].split(",")[0])
        limit = int(rest.split("limit ")[1].split()[0])
        out[name] = (secs, rc, limit)
    return out


LIM = limits()


def wall(name, run):
    if run is None:
        secs, rc, limit = LIM.get(name, (0, -1, 0))
        if rc == 0:
            return f"{secs} (the script's count; map.json not brought back)"
        return f"> {limit} (cut, rc {rc})"
    return f"{run[0]['timings_s']['total_s']:.1f}"


def agree(a, b, key, fn):
    both = fn(a[1][key], b[1][key])
    return both


def pct(mask):
    return f"{int(mask.sum())} of {mask.size} ({100 * mask.mean():.1f} %)"


runs = {n: load(n) for n in LIM}
first = next(r for r in runs.values() if r is not None)
print(f"# Adaptive steps on the GPU engine: {first[0]['adapter']}\n")
print("Written by `benches/adaptive_gpu.py` from the calls of `benches/gpu_lease.sh adaptive` (and "
      "`adaptive17`). "
      "One run each; wall times are each map's `timings_s.total_s` (the whole map: planning, "
      "pipelines, integration, reductions). Adaptive: rtol 1e-3 / atol 1e-5 (the defaults); "
      "tight: rtol 1e-4 / atol 1e-6.\n")

print("## The default map (64 × 48)\n")
print("| N | steps | wall (s) | chaotic | periodic | regular | undecided |")
print("|---|---|---:|---:|---:|---:|---:|")
for name, n, label in (("n3_fixed", 3, "fixed (auto method and step)"),
                       ("n3_adaptive", 3, "adaptive"),
                       ("n3_adaptive_imex", 3, "adaptive IMEX"), ("n3_tight", 3, "adaptive, tight"),
                       ("full9_adaptive", 9, "adaptive"), ("full17_fixed", 17, "fixed (IMEX, 63 µs)"),
                       ("full17_adaptive", 17, "adaptive")):
    if name not in LIM:
        continue
    r = runs[name]
    if r is None:
        # a map that finished but whose map.json did not come back: the script's wall time
        print(f"| {n} | {label} | {wall(name, r)} | | | | |")
        continue
    c = r[0]["regime"]["counts"]
    label = f"{label} ({r[0]['method']})"
    print(f"| {n} | {label} | {wall(name, r)} | {c['chaotic']} | {c['periodic']} | "
          f"{c['regular']} | {c['undecided']} |")
a, t = runs.get("n3_adaptive"), runs.get("n3_tight")
if a and t:
    pa, pt = a[1]["period"], t[1]["period"]
    both = (pa > 0) & (pt > 0)
    print(f"\nN = 3: periods equal between the default tolerance and the tight one on "
          f"{pct(pa[both] == pt[both])} of the cells periodic in both.")
f = runs.get("n3_fixed")
if f and a:
    print(f"Wall time adaptive / fixed at N = 3: "
          f"{a[0]['timings_s']['total_s'] / f[0]['timings_s']['total_s']:.2f}×.")

print("\n## The 192-cell subgrid at N = 17 (`configs/maps/default_subgrid.toml`, K and period)\n")
print("| steps | wall (s) | K class as tight | period as tight |")
print("|---|---:|---:|---:|")
tight = runs.get("sub17_tight")
for name, label in (("sub17_fixed", "fixed (IMEX, automatic step 63 µs)"),
                    ("sub17_adaptive", "adaptive"), ("sub17_tight", "adaptive, tight")):
    r = runs.get(name)
    if name not in LIM:
        continue
    if r is None or tight is None or name == "sub17_tight":
        print(f"| {label} | {wall(name, r)} | | |")
        continue
    k = (r[1]["K"] > 0.5) == (tight[1]["K"] > 0.5)
    p = r[1]["period"] == tight[1]["period"]
    print(f"| {label} | {wall(name, r)} | {pct(k)} | {pct(p)} |")
fx, ad = runs.get("sub17_fixed"), runs.get("sub17_adaptive")
if ad:
    if fx:
        k = (fx[1]["K"] > 0.5) == (ad[1]["K"] > 0.5)
        p = fx[1]["period"] == ad[1]["period"]
        ratio = fx[0]["timings_s"]["total_s"] / ad[0]["timings_s"]["total_s"]
        print(f"\nAdaptive against fixed: the same K class on {pct(k)}, the same period on {pct(p)}; "
              f"fixed / adaptive wall time {ratio:.1f}×.")
    else:
        _, _, limit = LIM["sub17_fixed"]
        ratio = limit / ad[0]["timings_s"]["total_s"]
        print(f"\nThe fixed-step subgrid did not finish within {limit} s: fixed / adaptive wall time "
              f"> {ratio:.1f}×.")

if "half17_fixed" in LIM or "half17_adaptive" in LIM:
    print("\n## The subgrid's upper half at N = 17 (f 8.06–11.6 Hz, 8 × 12 = 96 cells, 14 s, 2 s transient)\n")
    print("| steps | wall (s) |")
    print("|---|---:|")
    for name, label in (("half17_fixed", "fixed (IMEX, automatic step 63 µs)"),
                        ("half17_adaptive", "adaptive")):
        if name in LIM:
            print(f"| {label} | {wall(name, runs.get(name))} |")
    fx, ad = runs.get("half17_fixed"), runs.get("half17_adaptive")
    if fx and ad:
        k = (fx[1]["K"] > 0.5) == (ad[1]["K"] > 0.5)
        p = fx[1]["period"] == ad[1]["period"]
        ratio = fx[0]["timings_s"]["total_s"] / ad[0]["timings_s"]["total_s"]
        print(f"\nAdaptive against fixed: the same K class (K > 0.5) on {pct(k)}, the same period "
              f"on {pct(p)}; fixed / adaptive wall time {ratio:.1f}×.")
