"""benches/kernels_agree.py, the report of the lease's maps held against each other, on map
folders written here: its counts are the ones the arrays give."""

from __future__ import annotations

import importlib.util
import json

import numpy as np

from conftest import REPO


def script():
    spec = importlib.util.spec_from_file_location("kernels_agree", REPO / "benches" / "kernels_agree.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def write_map(folder, k, period, regime, total_s):
    folder.mkdir()
    meta = {"instances": int(np.size(k)), "timings_s": {"total_s": total_s}}
    (folder / "map.json").write_text(json.dumps(meta))
    np.save(folder / "K.npy", np.asarray(k, dtype=float))
    np.save(folder / "period.npy", np.asarray(period, dtype=float))
    np.save(folder / "regime.npy", np.asarray(regime, dtype=np.int8))


def test_the_report_counts_what_the_maps_hold(tmp_path):
    # Four cells: one K class differs (cell 3); cells 0-2 periodic in the first, cells 0 and 2
    # in the second, and their periods agree on cell 0 only; the regimes differ on cell 2.
    write_map(tmp_path / "old", [[0.1, 0.2], [0.1, 0.9]], [[3, 1], [2, 0]], [[1, 1], [1, 3]], 12.5)
    write_map(tmp_path / "new", [[0.1, 0.2], [0.1, 0.1]], [[3, 0], [4, 0]], [[1, 1], [3, 3]], 20.0)
    write_map(tmp_path / "parity_gpu", [0.1, 0.9], [1, 0], [1, 3], 1.0)
    lines = script().report(str(tmp_path), (("old", "new", "old against new"),))
    pair = next(line for line in lines if "old against new" in line)
    cells = [c.strip() for c in pair.strip("|").split("|")]
    assert cells[1:] == ["4", "3 of 4 (75.0 %)", "1 of 2 (50.0 %)", "3 of 4 (75.0 %)", "12.5 / 20.0"]
    # A pair of which one map did not come back is named, not compared.
    parity = next(line for line in script().report(str(tmp_path)) if "GPU f32 against CPU f64" in line)
    assert "not brought back: parity_cpu" in parity
    # Maps on different grids are not compared cell by cell.
    write_map(tmp_path / "parity_cpu", [0.1, 0.9, 0.2], [1, 0, 1], [1, 3, 1], 2.0)
    parity = next(line for line in script().report(str(tmp_path)) if "GPU f32 against CPU f64" in line)
    assert "different grids" in parity
