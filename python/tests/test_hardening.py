"""Issue 71: a settling map's cell reruns with the map's numbers, a cell value a few ulp off
its axis runs the grid value, an axis count of any integral type is a count, messages quote
inputs safely, and a map folder whose `--force` run was killed says where its map is."""

from __future__ import annotations

import json
import shutil
import subprocess
import warnings

import numpy as np
import pytest

import pendulum_atlas as pa
from conftest import cli_binary, run_cli

#: The small map without settling (as test_package's SETS).
RAW = {"beam.segments": 2, "map.early_stop": False}


def settling_scene(small_map_file) -> pa.Scene:
    """The small map as it comes: N = 3, and it settles (the default)."""
    return pa.Scene.from_toml(small_map_file)


def assert_map_cell_is_the_maps(values: dict, ds, f: float, a: float) -> None:
    """`attrs["map_cell"]` equals the map's stored values of the cell, bit for bit."""
    numbers = [n for n in values if n not in ("regime", "status")]
    assert {"K", "R", "period", "hops"} <= set(numbers), numbers
    for name in numbers:
        want = float(ds[name].sel(frequency_hz=f, amplitude_m=a))
        got = values[name]
        same = np.isnan(want) if got is None else got == want
        assert same, (name, f, a, got, want)
    attrs = ds["regime"].attrs
    meaning = dict(zip(attrs["flag_values"], attrs["flag_meanings"].split()))
    assert values["regime"] == meaning[int(ds["regime"].sel(frequency_hz=f, amplitude_m=a))]


def simulate_quietly(scene: pa.Scene):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return pa.simulate(scene, progress=False)


# -- 1. a settling map's cell ----------------------------------------------------------------


def test_every_cell_of_a_settling_map_reruns_with_the_maps_numbers_given_its_run(small_map_file):
    scene = settling_scene(small_map_file)
    ds = pa.map(scene, backend="cpu", precision="f64", progress=False)
    assert "ran_on" in ds.data_vars
    assert int(ds["ran_on"].sum()) > 0, "the test needs a cell the map ran on"
    for f in ds.frequency_hz.values:
        for a in ds.amplitude_m.values:
            cell = scene.cell(frequency_hz=float(f), amplitude_m=float(a), run=ds)
            assert "[cell]" in cell.to_toml()
            ran_on = bool(ds["ran_on"].sel(frequency_hz=f, amplitude_m=a))
            assert f"ran_on = {str(ran_on).lower()}" in cell.to_toml()
            run = simulate_quietly(cell)
            assert_map_cell_is_the_maps(run.attrs["map_cell"], ds, float(f), float(a))
            # ran_on (and copies, where the map ran the cell's nudged copies) given by hand
            # make the same scene.
            copies = bool(np.isfinite(ds["start_sensitivity"].sel(frequency_hz=f, amplitude_m=a)))
            assert ("copies = true" in cell.to_toml()) == copies
            by_hand = scene.cell(frequency_hz=float(f), amplitude_m=float(a), ran_on=ran_on, copies=copies)
            assert by_hand.to_toml() == cell.to_toml()


def test_a_cell_of_an_opened_map_folder_is_the_explorers_download(tmp_path, small_map_file):
    out = tmp_path / "map"
    run_cli("map", small_map_file, "--backend", "cpu", "--out", out, "--quiet")
    opened = pa.open_run(out)
    scene = pa.Scene.from_toml(out / "map_scene.toml")
    k = np.argwhere(opened["ran_on"].values == 1)
    i, j = k[0] if len(k) else (0, 0)
    f, a = float(opened.frequency_hz[i]), float(opened.amplitude_m[j])
    cell = scene.cell(frequency_hz=f, amplitude_m=a, run=opened)
    assert_map_cell_is_the_maps(simulate_quietly(cell).attrs["map_cell"], opened, f, a)
    # The command's `simulate` of the same scene reports the same values.
    path = tmp_path / "cell.toml"
    path.write_text(cell.to_toml(), encoding="utf-8")
    run_cli("simulate", path, "--out", tmp_path / "sim")
    report = json.loads((tmp_path / "sim" / "run.json").read_text())
    assert_map_cell_is_the_maps(report["map_cell"]["values"], opened, f, a)


def test_a_settling_maps_cell_without_its_run_says_it_cannot_be_rerun(tmp_path, small_map_file):
    scene = settling_scene(small_map_file)
    cell = scene.cell(frequency_hz=7.5, amplitude_m=0.009)
    assert "settle_max_s" in cell.to_toml() and "ran_on" not in cell.to_toml()
    with pytest.warns(UserWarning, match="settling map.*ran_on"):
        run = pa.simulate(cell, progress=False)
    assert "map_cell" not in run.attrs
    assert any("settling map" in w for w in run.attrs["warnings"])
    path = tmp_path / "cell.toml"
    path.write_text(cell.to_toml(), encoding="utf-8")
    done = run_cli("simulate", path, "--out", tmp_path / "sim")
    assert "warning:" in done.stderr and "settling map" in done.stderr, done.stderr
    assert "map_cell" not in json.loads((tmp_path / "sim" / "run.json").read_text())


def test_a_cell_refuses_a_run_of_another_map_and_ran_on_of_a_map_that_does_not_settle(small_map_file):
    scene = settling_scene(small_map_file)
    other = pa.map(scene.copy().set("map.axes", [{"key": "excitation.frequency_hz", "values": [5.0, 7.5, 10.0]},
                                                  {"key": "excitation.amplitude_m", "values": [0.009, 0.02]}]),
                   backend="cpu", progress=False)
    with pytest.raises(pa.SceneError, match="excitation.amplitude_m"):
        scene.cell(frequency_hz=7.5, amplitude_m=0.009, run=other)
    with pytest.raises(TypeError, match="not both"):
        scene.cell(frequency_hz=7.5, amplitude_m=0.009, run=other, ran_on=True)
    with pytest.raises(pa.SceneError, match="does not settle"):
        scene.copy().update(RAW).cell(frequency_hz=7.5, amplitude_m=0.009, ran_on=True)


# -- 2. a value a few ulp off its axis -------------------------------------------------------


def test_a_cell_value_a_few_ulp_off_its_axis_runs_the_grid_value(small_map_file):
    scene = pa.Scene.from_toml(small_map_file).update(RAW)
    ds = pa.map(scene, backend="cpu", precision="f64", progress=False)
    off = 7.5 * (1 + 4e-12)
    with pytest.warns(UserWarning, match=rf"excitation.frequency_hz = {off!r} .*grid value 7.5:"):
        cell = scene.cell(frequency_hz=off, amplitude_m=0.009)
    assert "frequency_hz = 7.5\n" in cell.to_toml()
    assert cell.to_toml() == scene.cell(frequency_hz=7.5, amplitude_m=0.009).to_toml()
    assert_map_cell_is_the_maps(simulate_quietly(cell).attrs["map_cell"], ds, 7.5, 0.009)


def test_a_cell_value_off_its_axis_is_refused_with_the_nearest_grid_values(small_map_file):
    scene = pa.Scene.from_toml(small_map_file)
    with pytest.raises(pa.SceneError) as refused:
        scene.cell(frequency_hz=7.5 * (1 + 1e-7), amplitude_m=0.009)
    message = str(refused.value)
    assert "excitation.frequency_hz" in message and "the nearest: 5, 7.5, 10" in message, message
    # A value exactly on the grid runs without a warning.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scene.cell(frequency_hz=5.0, amplitude_m=0.009)


# -- 3. an axis count of any integral type ---------------------------------------------------


def test_an_axis_count_of_any_integral_type_is_a_count(small_map_file):
    scene = pa.Scene.from_toml(small_map_file).update(RAW)
    ds = pa.map(scene, backend="cpu", progress=False,
                axes={"excitation.frequency_hz": (5.0, 10.0, np.int64(3)), "excitation.amplitude_m": (0.009, 0.023, 2.0)})
    np.testing.assert_array_equal(ds["frequency_hz"].values, [5.0, 7.5, 10.0])
    np.testing.assert_array_equal(ds["amplitude_m"].values, [0.009, 0.023])
    for count in (3, np.int32(3), np.uint8(3), 3.0, np.float64(3.0), np.float32(3.0)):
        (axis,) = pa._axes_list({"excitation.frequency_hz": (5.0, 10.0, count)})
        assert axis == {"key": "excitation.frequency_hz", "start": 5.0, "end": 10.0, "count": 3}
        assert type(axis["count"]) is int
    # Only a list (or an array) is a list of values.
    (axis,) = pa._axes_list({"excitation.frequency_hz": [5.0, 10.0, 13.0]})
    assert axis["values"] == [5.0, 10.0, 13.0]


@pytest.mark.parametrize("count", [13.5, np.float64(2.5), "13", True])
def test_an_axis_count_that_is_not_a_whole_number_is_refused(small_map_file, count):
    scene = pa.Scene.from_toml(small_map_file)
    with pytest.raises((ValueError, TypeError), match="count of \\(start, end, count\\) is a whole number"):
        pa.map(scene, backend="cpu", progress=False, axes={"excitation.frequency_hz": (5.0, 10.0, count)})


# -- 4. control characters -------------------------------------------------------------------


def test_an_unknown_short_name_of_a_cell_reaches_the_message_escaped(small_map_file):
    scene = pa.Scene.from_toml(small_map_file)
    with pytest.raises(ValueError) as refused:
        scene.cell(**{"fr\x1b]0;owned\x07\x1b[2J": 7.5})
    message = str(refused.value)
    assert "is not the short name of one axis" in message
    assert not any(c in message for c in "\x1b\x07"), message
    assert "\\u{1b}]0;owned" in message


def test_open_run_of_a_missing_folder_reaches_the_message_escaped(tmp_path):
    with pytest.raises(FileNotFoundError) as refused:
        pa.open_run(tmp_path / "no\x1b]0;owned\x07\x1b[2Jmap")
    message = str(refused.value)
    assert "has no map.json" in message
    assert not any(c in message for c in "\x1b\x07"), message
    assert "\\u{1b}]0;owned" in message


# -- 5. a `--force` run killed outright ------------------------------------------------------


def test_open_run_of_a_map_whose_force_run_was_killed_says_where_the_earlier_map_is(tmp_path, small_map_file):
    out = tmp_path / "map"
    run_cli("map", small_map_file, "--backend", "cpu", "--out", out, "--quiet")
    manifest = json.loads((out / "map.json").read_text())
    # What a `--force` run killed by SIGKILL leaves: the earlier map's files set aside.
    aside = out / ".pendulum-atlas.earlier"
    aside.mkdir()
    for name in [*manifest["files"], "map.json"]:
        if (out / name).is_file():
            shutil.move(out / name, aside / name)
    with pytest.raises(FileNotFoundError) as refused:
        pa.open_run(out)
    message = str(refused.value)
    assert ".pendulum-atlas.earlier" in message and "earlier complete map" in message, message
    assert "next" in message and "puts it back" in message, message
    # And the next run into the folder does put it back first (then replaces it).
    subprocess.run([str(cli_binary()), "map", small_map_file, "--backend", "cpu", "--out", out, "--quiet",
                    "--force", "--set", "beam.segments=2"], check=True, capture_output=True)
    assert pa.open_run(out).attrs["segments"] == 2
