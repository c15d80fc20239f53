"""How often a map cell's rerun gives the map's numbers (issue 61): an 8 x 6 version of the
default plane on the CPU engine in f64, each cell rerun as `Scene.cell` pins it and run by
`pa.simulate`; the K class (K > 0.5) and the period compared with the map's, as the map
computes the cell (`map_cell`, the default) or from the record's own analysis (`--record`).

    python benches/cell_rerun.py            # the cell's map values (run.json's map_cell)
    python benches/cell_rerun.py --record   # the record's own analysis of the pinned cell
    python benches/cell_rerun.py --record --fixed  # ... with the earlier pinning: fixed steps

Needs the package installed (`pip install .`). About 10 s on 2 cores.
"""

import sys
import tomllib

import numpy as np

import pendulum_atlas as pa

fixed = "--fixed" in sys.argv[1:]
record = "--record" in sys.argv[1:]
scene = pa.Scene.default_map().set("map.axes", [
    {"key": "excitation.frequency_hz", "start": 4.0, "end": 12.0, "count": 8},
    {"key": "excitation.amplitude_m", "start": 0.004, "end": 0.025, "count": 6},
])
ds = pa.map(scene, backend="cpu", precision="f64", progress=False)
same_k = same_period = cells = 0
differ = []
for f in ds.frequency_hz.values:
    for a in ds.amplitude_m.values:
        cell = scene.cell(frequency_hz=float(f), amplitude_m=float(a))
        if fixed:
            base = tomllib.loads(cell.to_toml())["integration"]["base_step_s"]
            cell = pa.Scene(cell.to_toml()).set("integration.step", "fixed").set("integration.dt_s", base)
        run = pa.simulate(cell, progress=False)
        k_map = float(ds["K"].sel(frequency_hz=f, amplitude_m=a))
        p_map = float(ds["period"].sel(frequency_hz=f, amplitude_m=a))
        if record:
            # The record's own analysis (simulate's K and period of its trajectory).
            k_run = float(run.attrs.get("K", np.nan))
            p_run = float(run.attrs.get("period") or 0)
        else:
            # The cell as its map computes it (run.json's map_cell).
            cell_values = run.attrs["map_cell"]
            k_run = float(cell_values["K"] if cell_values["K"] is not None else np.nan)
            p_run = float(cell_values["period"] or 0)
        cells += 1
        same_k += (k_map > 0.5) == (k_run > 0.5)
        same_period += p_map == p_run
        if (k_map > 0.5) != (k_run > 0.5) or p_map != p_run:
            differ.append(f"  f = {f:.3f} Hz, A = {a * 1e3:.1f} mm: K {k_map:.3f} (map) {k_run:.3f} (rerun), period {p_map:g} / {p_run:g}")
what = "record analysis, " if record else "map_cell, "
print(f"{what}{'fixed steps of the base step' if fixed else 'adaptive steps as the map'}: "
      f"K class as the map's on {same_k} of {cells} cells, period on {same_period} of {cells}")
print("\n".join(differ))
