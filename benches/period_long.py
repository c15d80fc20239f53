"""Do the default map's period-5 and period-6 cells hold their period over a long run?
(issue 72, item 3: the period detector called period 6 an orbit the converged reference gives
as period 3.) Each cell the map calls periodic with period 5 or 6 is run alone as a map of one
cell, settling off, once at the map's length (34 s, indicators from 10 s) and once ten times
longer (334 s, indicators over the same 24 s window at its end); the detector's period of each
is printed with the map's own period, confidence and ran_on.

    python benches/period_long.py runs/map          # a default map's folder (map.json beside it)

Needs numpy and the release binary (target/release/pendulum-atlas). About 2 minutes on 2 cores.
"""

import pathlib
import subprocess
import sys
import tempfile
from collections import Counter

import numpy as np

BIN = "target/release/pendulum-atlas"
LENGTHS = ((34.0, 10.0), (334.0, 310.0))


def period_of_cell(f: float, a: float, duration: float, transient: float, out: str) -> int:
    axes = (
        f'map.axes=[{{key="excitation.frequency_hz",values=[{f!r}]}},'
        f'{{key="excitation.amplitude_m",values=[{a!r}]}}]'
    )
    subprocess.run(
        [BIN, "map", "--backend", "cpu", "--quiet", "--force", "--out", out, "--set", axes,
         "--set", f"integration.duration_s={duration}",
         "--set", f"integration.transient_s={transient}", "--set", "map.settle=false"],
        check=True, capture_output=True)
    return int(np.load(f"{out}/period.npy").ravel()[0])


def main(folder: pathlib.Path) -> None:
    load = lambda name: np.load(folder / name)  # noqa: E731
    period, regime, conf = load("period.npy"), load("regime.npy"), load("verdict_confidence.npy")
    ran_on, f, a = load("ran_on.npy"), load("axis0.npy"), load("axis1.npy")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for p in (6, 5):
            for i, j in np.argwhere((period == p) & (regime == 1)):
                found = [period_of_cell(float(f[i]), float(a[j]), d, t, f"{tmp}/m")
                         for d, t in LENGTHS]
                rows.append([p, float(f[i]), float(a[j]), round(float(conf[i, j]), 2),
                             int(ran_on[i, j]), *found])
                print(rows[-1], flush=True)
    for p in (6, 5):
        mine = [r for r in rows if r[0] == p]
        print(f"period {p}: {len(mine)} cells, {sum(r[4] for r in mine)} ran on by the map; "
              f"at 34 s {dict(Counter(r[5] for r in mine))}, at 334 s {dict(Counter(r[6] for r in mine))}")


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "runs/map"))
