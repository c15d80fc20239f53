"""The orbit stage on the default map (issue 74), measured against the map's own verdict and
the verdict study's converged reference of the forcing plane's subgrid.

    python benches/orbits_study.py runs/map [docs/bench/verdict.json]

The folder is `cargo run --release -- map` (the README's main command). The reference is the
study's (`pendulum-atlas-lab verdict`): every 4th value of each axis, fixed 1e-4 s RK4 steps,
1000 s and 2000 s runs that agree ("settled"). Prints what docs/bench/ORBITS.md quotes.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

PERIODIC, CHAOTIC = 1, 3
CONVERGED, DISTANT = 0, 5


def main(folder: Path, reference: Path) -> None:
    a = {n: np.load(folder / f"{n}.npy") for n in (
        "regime", "period", "orbit_status", "orbit_period", "floquet_max", "floquet_minus1",
        "orbits_known", "orbits_stable")}
    m = json.loads((folder / "map.json").read_text())
    o, t = m["orbits"], m["timings_s"]
    map_s = t["total_s"] - t["orbits_s"]
    periodic = a["regime"] == PERIODIC
    shot = a["orbit_status"] >= 0
    conv = a["orbit_status"] == CONVERGED
    print(f"cells {a['regime'].size}, periodic {periodic.sum()}, shot {shot.sum()}")
    print("orbit status counts:", o["status_counts"])
    print(f"converged own orbit: {conv.sum()} of {shot.sum()} = {conv.sum() / shot.sum():.4f}")
    print(f"stage {t['orbits_s']:.2f} s ({o['timings_s']}), map without it {map_s:.2f} s, "
          f"ratio {t['orbits_s'] / map_s:.3f}")
    print(f"families {o['families']}, orbits known {o['orbits_known']}, continued tries "
          f"{o['continued_tries']}, found {o['continued_found']}, curves {o['curves']}")
    stable = conv & (a["floquet_max"] < 1)
    print(f"own orbits stable: {stable.sum()} of {conv.sum()}")
    diff = conv & (a["orbit_period"] != a["period"])
    print(f"own orbit's least period differs from the map's: {diff.sum()} cells")
    for p, q in sorted({(int(a['period'][i]), int(a['orbit_period'][i])) for i in zip(*np.nonzero(diff))}):
        n = (diff & (a["period"] == p) & (a["orbit_period"] == q)).sum()
        mu = a["floquet_max"][diff & (a["period"] == p) & (a["orbit_period"] == q)]
        print(f"  map {p} -> orbit {q}: {n} cells, largest |multiplier| in [{mu.min():.3f}, {mu.max():.3f}]")
    chaos_stable = (a["regime"] == CHAOTIC) & (a["orbits_stable"] > 0)
    print(f"chaotic cells carrying a stable known orbit: {chaos_stable.sum()} of {(a['regime'] == CHAOTIC).sum()}")

    ref = json.loads(reference.read_text())
    r = ref["reference"]
    thin, shape = ref["thin"], tuple(ref["shape"])
    sub = lambda x: x[::thin, ::thin]
    rr, rp = np.array(r["regime"]).reshape(shape), np.array(r["period"]).reshape(shape)
    settled = np.array(r["is_settled"], dtype=bool).reshape(shape)
    ref_periodic = settled & (rr == PERIODIC)
    print(f"\nreference ({ref['plane']} plane, every {thin}th value, {r['durations_s']} s): "
          f"{settled.sum()} settled, {ref_periodic.sum()} periodic")
    c, op, mp = sub(conv), sub(a["orbit_period"]), sub(a["period"])
    both = ref_periodic & c
    print(f"reference-periodic cells with a converged own orbit: {both.sum()} of {ref_periodic.sum()}")
    print(f"  orbit period = reference period: {(op[both] == rp[both]).sum()} of {both.sum()}")
    print(f"  map period   = reference period: {(mp[both] == rp[both]).sum()} of {both.sum()}")
    for i, j in zip(*np.nonzero(both & (op != rp))):
        print(f"    cell ({i * thin}, {j * thin}): orbit {op[i, j]}, map {mp[i, j]}, reference {rp[i, j]}")
    cs = sub(chaos_stable)
    print(f"map-chaotic subgrid cells carrying a stable known orbit: {cs.sum()}; of those the "
          f"reference calls periodic: {(cs & ref_periodic).sum()}, chaotic: {(cs & settled & (rr == CHAOTIC)).sum()}")
    mc = sub(a["regime"] == CHAOTIC) & ref_periodic
    print(f"map-chaotic subgrid cells the reference calls periodic: {mc.sum()}; of those carrying "
          f"a stable known orbit: {(mc & cs).sum()}")


if __name__ == "__main__":
    folder = Path(sys.argv[1] if len(sys.argv) > 1 else "runs/map")
    reference = Path(sys.argv[2] if len(sys.argv) > 2 else "docs/bench/verdict.json")
    main(folder, reference)
