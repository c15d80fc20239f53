"""The Python package against the command line it wraps: the same scene gives the same
arrays bit for bit, coordinates carry the axes and their units, bad scenes raise with the
library's message, and a map folder opens as the dataset the package returns."""

from __future__ import annotations

import json
import os
import signal
import threading
import time

import numpy as np
import pytest
import xarray as xr

import pendulum_atlas as pa
from conftest import SMALL_MAP, gpu_backends, run_cli

SETS = {"beam.segments": 2, "map.early_stop": False}


def cli_map(tmp_path, scene_file, backend, sets=SETS):
    out = tmp_path / f"cli_{backend}"
    args = ["map", scene_file, "--backend", backend, "--out", out, "--quiet"]
    for key, value in sets.items():
        args += ["--set", f"{key}={json.dumps(value)}"]
    run_cli(*args)
    return out


@pytest.mark.parametrize("backend", gpu_backends())
def test_map_equals_the_cli_npy_files_bit_for_bit(tmp_path, small_map_file, backend):
    out = cli_map(tmp_path, small_map_file, backend)
    ds = pa.map(pa.Scene.from_toml(small_map_file).update(SETS), backend=backend, progress=False)
    manifest = json.loads((out / "map.json").read_text())
    npy = [f[:-4] for f in manifest["files"] if f.endswith(".npy") and not f.startswith("axis")]
    assert set(npy) == set(ds.data_vars), "the same arrays"
    for name in npy:
        cli = np.load(out / f"{name}.npy")
        ours = ds[name].values
        assert ours.dtype == cli.dtype and ours.shape == cli.shape, name
        assert ours.tobytes() == cli.tobytes(), f"{name} differs from {name}.npy"
    assert json.loads(ds.attrs["map_json"])["backend"] == backend


@pytest.mark.parametrize("backend", gpu_backends())
def test_the_engine_is_opened_once_per_process_and_reused(small_map_file, backend):
    scene = pa.Scene.from_toml(small_map_file).update(SETS)
    first = pa.map(scene, backend=backend, progress=False)
    second = pa.map(scene, backend=backend, progress=False)
    manifest = json.loads(second.attrs["map_json"])
    assert manifest["backend_reason"].endswith("(reused: opened by an earlier call of this process)")
    assert manifest["timings_s"]["device_s"] == 0.0
    assert manifest["backend"] == backend
    for name in first.data_vars:
        assert first[name].values.tobytes() == second[name].values.tobytes(), name


def test_coordinates_carry_the_axes_and_their_units(small_map_file):
    ds = pa.map(pa.Scene.from_toml(small_map_file), backend="cpu", progress=False)
    assert ds["K"].dims == ("frequency_hz", "amplitude_m")
    np.testing.assert_array_equal(ds["frequency_hz"].values, np.linspace(5.0, 10.0, 3))
    np.testing.assert_array_equal(ds["amplitude_m"].values, np.linspace(0.009, 0.023, 2))
    assert ds["frequency_hz"].attrs["units"] == "Hz"
    assert ds["frequency_hz"].attrs["key"] == "excitation.frequency_hz"
    assert ds["amplitude_m"].attrs["units"] == "m"
    assert ds["lyapunov"].attrs["units"] == "1/s"
    assert ds["alpha_max_rad"].attrs["units"] == "rad"
    meanings = dict(zip(ds["regime"].attrs["flag_meanings"].split(), ds["regime"].attrs["flag_values"]))
    assert meanings["chaotic"] == 3 and meanings["periodic"] == 1
    assert ds["regime"].dtype == np.int8 and ds["status"].dtype == np.uint8
    manifest = json.loads(ds.attrs["map_json"])
    assert manifest["shape"] == [3, 2] and ds.attrs["segments"] == 3


def test_the_dataset_holds_every_result_of_the_schema_the_map_formed(small_map_file):
    ds = pa.map(pa.Scene.from_toml(small_map_file), backend="cpu", progress=False)
    metrics = json.loads(ds.attrs["map_json"])["metrics"]
    fields = _native_fields()
    assert {f["name"] for f in fields} >= {"K", "regime", "status"}
    for f in fields:
        formed = f["metric"] is None or f["metric"] in metrics
        assert (f["name"] in ds.data_vars) == formed, f["name"]
        if not formed:
            continue
        var = ds[f["name"]]
        assert var.dtype == np.dtype(f["dtype"]), f["name"]
        assert var.attrs["long_name"] == f["description"], f["name"]
        if f["dtype"] == "float64":
            assert var.attrs["units"] == f["unit"], f["name"]
    schema = {f["name"] for f in fields}
    # Besides the schema's results, the orbit and transient stages' arrays, which map.json names.
    manifest = json.loads(ds.attrs["map_json"])
    stage = set(manifest["orbits"]["arrays"]) | set((manifest["transients"] or {}).get("arrays", {}))
    assert stage and not stage & schema
    assert set(ds.data_vars) <= schema | stage, "no variable outside the schema and the stage's arrays"


def _native_fields():
    from pendulum_atlas import _native

    return _native.result_fields()


def test_a_one_axis_map_with_full_keys_when_names_clash():
    scene = pa.Scene(SMALL_MAP).set(
        "map.axes",
        [
            {"key": "beam.damping_ratio", "values": [0.01, 0.02]},
            {"key": "excitation.frequency_hz", "values": [6.0]},
        ],
    )
    ds = pa.map(scene, backend="cpu", progress=False)
    assert ds["K"].dims == ("damping_ratio", "frequency_hz")
    assert ds["damping_ratio"].attrs["units"] == "1"


def test_open_run_on_a_cli_folder_equals_the_package_map(tmp_path, small_map_file):
    out = cli_map(tmp_path, small_map_file, "cpu")
    opened = pa.open_run(out)
    ours = pa.map(pa.Scene.from_toml(small_map_file).update(SETS), backend="cpu", progress=False)
    xr.testing.assert_equal(opened, ours)
    for name in ours.variables:
        assert opened[name].attrs == ours[name].attrs, name
    assert "K.npy" in json.loads(opened.attrs["map_json"])["files"]


def test_the_dataset_carries_the_orbit_stage_arrays_and_its_curves(tmp_path, small_map_file):
    out = cli_map(tmp_path, small_map_file, "cpu")
    opened = pa.open_run(out)
    ours = pa.map(pa.Scene.from_toml(small_map_file).update(SETS), backend="cpu", progress=False)
    for ds in (opened, ours):
        for name in ("orbit_status", "orbit_period", "floquet_max", "orbits_known", "orbits_stable"):
            assert name in ds, name
        meanings = ds["orbit_status"].attrs["flag_meanings"].split()
        assert meanings[:2] == ["not_periodic", "converged"]
        periodic = ds["regime"].values == 1
        assert periodic.any()
        # Every cell the map calls periodic was shot; the rest were not.
        assert (ds["orbit_status"].values[periodic] >= 0).all()
        assert (ds["orbit_status"].values[~periodic] == -1).all()
        curves = json.loads(ds.attrs["bifurcations_json"])
        assert set(curves) >= {"axes", "curves", "tolerance"}
    assert json.loads(opened.attrs["bifurcations_json"]) == json.loads(ours.attrs["bifurcations_json"])


def test_the_dataset_carries_the_copies_sensitivity_and_lifetime(tmp_path, small_map_file):
    # A map that settles (the early stop on) runs nudged copies of the cells it leaves not firm.
    sets = {"beam.segments": 2, "map.transient_copies": 2}
    out = cli_map(tmp_path, small_map_file, "cpu", sets)
    opened = pa.open_run(out)
    ours = pa.map(pa.Scene.from_toml(small_map_file).update(sets), backend="cpu", progress=False)
    xr.testing.assert_equal(opened, ours)
    manifest = json.loads(opened.attrs["map_json"])
    assert manifest["transients"]["copies"] == 2
    s = opened["start_sensitivity"]
    assert s.attrs["units"] == "1" and "nudged copies" in s.attrs["long_name"]
    assert opened["transient_s"].attrs["units"] == "s"
    values = s.values[np.isfinite(s.values)]
    assert ((values >= 0) & (values <= 1)).all()
    # Where the start decides, the verdict is never firm.
    assert (opened["verdict_confidence"].values[s.values > 0] < 0.9).all()
    # Cells that ran no copies were firm after settling: no sensitivity, no lifetime.
    assert np.isnan(opened["transient_s"].values[np.isnan(s.values)]).all()


def test_open_run_of_a_merged_map_equals_the_whole_map(tmp_path, small_map_file):
    shards = []
    for i in range(2):
        d = tmp_path / f"shard{i}"
        run_cli("map", small_map_file, "--backend", "cpu", "--shard", f"{i}/2", "--out", d, "--quiet")
        shards.append(d)
    with pytest.raises(ValueError, match="merge the shards"):
        pa.open_run(shards[0])
    run_cli("merge", *shards, "--out", tmp_path / "merged")
    whole = pa.map(pa.Scene.from_toml(small_map_file), backend="cpu", progress=False)
    xr.testing.assert_equal(pa.open_run(tmp_path / "merged"), whole)


def test_open_run_of_a_folder_without_a_map_says_what_it_reads(tmp_path):
    with pytest.raises(FileNotFoundError, match="map.json"):
        pa.open_run(tmp_path)


def test_open_run_refuses_a_damaged_map_json_and_paths_out_of_the_folder(tmp_path, small_map_file):
    out = cli_map(tmp_path, small_map_file, "cpu")
    manifest = json.loads((out / "map.json").read_text())
    manifest["files"].append("../../secret.npy")
    (out / "map.json").write_text(json.dumps(manifest))
    with pytest.raises(ValueError, match="not a file name of its folder"):
        pa.open_run(out)
    (out / "map.json").write_text(json.dumps({"files": []}))
    with pytest.raises(ValueError, match="does not hold the fields this version writes"):
        pa.open_run(out)


@pytest.mark.parametrize(
    "key, value, names",
    [
        ("beam.segments", 0, "beam.segments"),
        ("excitation.frequency_hz", -3.0, "excitation.frequency_hz"),
        ("beam.segmnts", 3, "beam.segmnts"),
        ("integration.method", "euler", "integration.method"),
    ],
)
def test_bad_values_raise_the_library_message_and_leave_the_scene_as_it_was(key, value, names):
    scene = pa.Scene.paper()
    before = scene.sets
    with pytest.raises(pa.SceneError, match=names.replace(".", r"\.")) as err:
        scene.set(key, value)
    assert isinstance(err.value, ValueError)
    assert scene.sets == before


def test_bad_scenes_and_arguments_raise_before_any_work():
    with pytest.raises(pa.SceneError, match="line"):
        pa.Scene("[beam\nsegments = 3")
    with pytest.raises(FileNotFoundError, match="no_such.toml"):
        pa.Scene.from_toml("configs/no_such.toml")
    with pytest.raises(TypeError, match="object"):
        pa.Scene.paper().set("beam.segments", object())
    with pytest.raises(pa.SceneError, match=r"no \[map\] section"):
        pa.map(pa.Scene.paper())
    with pytest.raises(pa.SceneError, match=r"\[map\] section"):
        pa.simulate(pa.Scene.default_map())
    with pytest.raises(ValueError, match="backend"):
        pa.map(pa.Scene(SMALL_MAP), backend="tpu", progress=False)
    with pytest.raises(ValueError, match="precision"):
        pa.map(pa.Scene(SMALL_MAP), precision="f16", progress=False)
    with pytest.raises(pa.EngineError, match="f32"):
        pa.map(pa.Scene(SMALL_MAP), backend="gpu", precision="f64", progress=False)
    with pytest.raises(pa.EngineError, match="f64") as raised:
        pa.simulate(pa.Scene.paper(), integrator="reference", precision="f32")
    # The exception is named as the package exports it, in tracebacks too.
    assert type(raised.value).__name__ == "EngineError"
    assert type(raised.value).__module__ == "pendulum_atlas"


def test_a_scene_round_trips_through_its_toml_and_cli_arguments(tmp_path):
    scene = pa.Scene.default_map().set("beam.segments", 4).set("integration.duration_s", 40.0)
    assert scene.cli_args() == ["--set", "beam.segments=4", "--set", "integration.duration_s=40.0"]
    with pytest.raises(pa.SceneError, match="axis of this map"):
        scene.set("excitation.amplitude_m", 0.01)
    again = pa.Scene(scene.to_toml())
    assert again.to_toml() == scene.to_toml()
    cell = scene.cell(frequency_hz=4.0, amplitude_m=0.004)
    assert not cell.is_map and "frequency_hz = 4.0" in cell.to_toml()


def test_simulate_equals_the_cli_trajectory_and_its_analysis(tmp_path):
    sets = {"beam.segments": 3, "integration.duration_s": 20.0, "integration.transient_s": 5.0}
    out = tmp_path / "sim"
    run_cli("simulate", *[a for k, v in sets.items() for a in ("--set", f"{k}={v}")], "--out", out)
    ds = pa.simulate(pa.Scene.paper().update(sets), progress=False)
    csv = np.genfromtxt(out / "trajectory.csv", delimiter=",", names=True)
    np.testing.assert_array_equal(ds["time"].values, csv["t_s"])
    for name in csv.dtype.names[1:]:
        np.testing.assert_array_equal(ds[name].values, csv[name], err_msg=name)
    report = json.loads((out / "run.json").read_text())
    assert ds.attrs["K"] == report["analysis"]["zero_one"]["K"]
    assert ds.attrs["R"] == report["analysis"]["phase_sync"]["R"]
    assert ds.attrs["lambda1_per_s"] == report["lyapunov"]["per_s"]
    assert ds["alpha_rad"].attrs["units"] == "rad" and ds["time"].attrs["units"] == "s"


def test_analyze_of_a_run_equals_the_runs_own_analysis():
    scene = pa.Scene.paper().update({"beam.segments": 3, "integration.duration_s": 20.0, "integration.transient_s": 5.0})
    ds = pa.simulate(scene, progress=False)
    got = pa.analyze(
        ds["alpha_rad"].values,
        sample_rate_hz=1.0 / float(ds["time"][1] - ds["time"][0]),
        forcing_hz=8.0,
        reference=ds["x0_m"].values,
        transient_s=5.0,
        clearance_deg=20.0,
    )
    run = json.loads(ds.attrs["run_json"])["analysis"]
    assert got["zero_one"]["K"] == run["zero_one"]["K"]
    assert got["phase_sync"]["R"] == run["phase_sync"]["R"]
    assert got["statistics"]["hops"] == run["statistics"]["hops"]


def test_analyze_tells_a_locked_sine_from_noise():
    rate, f = 200.0, 4.0
    t = np.arange(0, 60, 1 / rate)
    cart = np.sin(2 * np.pi * f * t)
    locked = pa.analyze(0.3 * np.sin(2 * np.pi * f * t + 0.4), rate, forcing_hz=f, reference=cart)
    assert locked["statistics"]["period"] == 1
    assert locked["phase_sync"]["R"] > 0.99
    assert locked["zero_one"]["K"] < 0.2
    noise = np.random.default_rng(7).standard_normal(t.size)
    random = pa.analyze(noise, rate, forcing_hz=f)
    assert random["zero_one"]["K"] > 0.8
    with pytest.raises(ValueError, match="forcing"):
        pa.analyze(noise, rate, sampling="stroboscopic")
    with pytest.raises(ValueError, match="shape"):
        pa.analyze(noise, rate, reference=noise[:10])


def test_a_progress_callback_that_raises_stops_the_map_and_the_next_map_runs():
    from pendulum_atlas import _native

    scene = pa.Scene(SMALL_MAP).set(
        "map.axes", [{"key": "excitation.frequency_hz", "start": 4.0, "end": 12.0, "count": 64}]
    ).set("integration.duration_s", 60.0)
    seen = []

    def stop(done, total, unit):
        seen.append((done, total, unit))
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        _native.run_map_scene(scene.text, scene.origin, scene.sets, "cpu", None, stop)
    # The first report seen is within the map: planning (done or not), or integration before
    # its last instance.
    assert seen and (seen[0][2] == "planned" or seen[0][0] < seen[0][1]), seen
    assert pa.map(pa.Scene(SMALL_MAP), backend="cpu", progress=False)["K"].size == 6


def test_ctrl_c_interrupts_a_running_map():
    scene = pa.Scene(SMALL_MAP).set(
        "map.axes", [{"key": "excitation.frequency_hz", "start": 4.0, "end": 12.0, "count": 256}]
    ).set("integration.duration_s", 100.0)
    timer = threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    started = time.monotonic()
    try:
        with pytest.raises(KeyboardInterrupt):
            pa.map(scene, backend="cpu", progress=False)
    finally:
        timer.cancel()
    assert time.monotonic() - started >= 0.5


def test_a_progress_bar_is_shown_on_stderr(capsys):
    pa.map(pa.Scene(SMALL_MAP), backend="cpu", progress=True)
    # tqdm writes to stderr; the bar is left off the screen when it closes.
    assert "map" in capsys.readouterr().err


def test_other_threads_run_while_the_engine_works():
    scene = pa.Scene(SMALL_MAP).set(
        "map.axes", [{"key": "excitation.frequency_hz", "start": 4.0, "end": 12.0, "count": 128}]
    ).set("integration.duration_s", 60.0)
    finished = threading.Event()
    worker = threading.Thread(target=lambda: (pa.map(scene, backend="cpu", progress=False), finished.set()))
    worker.start()
    ticks = 0
    while not finished.is_set() and worker.is_alive():
        ticks += 1
        time.sleep(0.001)
    worker.join()
    assert finished.is_set(), "the map ran to its end"
    # Were the interpreter's lock held for the whole map, this loop would not run until the end.
    assert ticks >= 50, f"the main thread ran {ticks} times while the map ran"


def test_a_map_with_starts_has_basin_fractions_over_an_attractor_label_axis(tmp_path, small_map_file):
    scene = (
        pa.Scene(SMALL_MAP)
        .set("map.axes", [
            {"key": "excitation.frequency_hz", "values": [7.8, 8.0]},
            {"key": "excitation.amplitude_m", "values": [0.001]},
        ])
        .set("integration.duration_s", 30.0)
        .set("integration.transient_s", 15.0)
        .set("map.initial_states", 6)
    )
    ds = pa.map(scene, backend="cpu", progress=False)
    fractions = ds["basin_fraction"]
    assert fractions.dims == ("attractor_label", "frequency_hz", "amplitude_m")
    total = fractions.sum("attractor_label") + ds["failed_fraction"]
    np.testing.assert_allclose(total.values, 1.0, rtol=0, atol=1e-12)
    assert (ds["attractors"].values == 2).all(), "both wells' orbits in each cell"
    # The same arrays as the command writes.
    out = tmp_path / "map"
    run_cli("map", small_map_file, *scene.cli_args(), "--backend", "cpu", "--quiet", "--out", out)
    for name in ["basin_fraction", "attractor", "attractors", "failed_fraction"]:
        on_disk = np.load(out / f"{name}.npy")
        assert on_disk.dtype == ds[name].dtype and np.array_equal(on_disk, ds[name].values), name


def test_a_map_run_both_ways_has_both_directions_and_their_hysteresis():
    scene = (
        pa.Scene(SMALL_MAP)
        .set("map.axes", [{"key": "excitation.frequency_hz", "values": [9.0, 10.0, 10.5, 11.0, 11.5, 12.0]}])
        .set("integration.duration_s", 36.0)
        .set("integration.transient_s", 12.0)
        .set("excitation.amplitude_m", 0.001)
        .set("map.metrics", ["period", "alpha_range", "regime"])
        .set("map.lyapunov_window_s", 6.0)
        .set("map.continuation", "both")
    )
    ds = pa.map(scene, backend="cpu", progress=False)
    # The pinned band of the engine suite: period 2 sweeping down from 12 Hz to 10 Hz.
    assert ds["period"].values.tolist() == [1.0] * 6
    assert ds["period_down"].values.tolist() == [1.0, 2.0, 2.0, 2.0, 2.0, 2.0]
    assert ds["period_down"].dims == ("frequency_hz",)
    assert ds["hysteresis"].values.tolist() == [0, 1, 1, 1, 1, 1]
    assert ds["regime_down"].attrs["flag_meanings"] == ds["regime"].attrs["flag_meanings"]
    bands = json.loads(ds.attrs["map_json"])["continuation"]["hysteresis"]["bands"]
    assert [(b["from"], b["to"]) for b in bands] == [(10.0, 12.0)]


def test_a_record_read_and_analysed_in_python_equals_the_cli_analysis(tmp_path):
    # Jittered time stamps: the reader resamples at the median rate, as the command does.
    rate, f = 200.0, 5.0
    rng = np.random.default_rng(3)
    t = np.arange(20000) / rate + rng.uniform(-2e-4, 2e-4, 20000)
    x = 0.3 * np.sin(2 * np.pi * f * t + 0.4)
    cart = 0.01 * np.sin(2 * np.pi * f * t)
    data = tmp_path / "rig.csv"
    rows = "\n".join(f"{a:.17g},{b:.17g},{c:.17g}" for a, b, c in zip(t, x, cart))
    data.write_text("t_s,x_rad,cart_m\n" + rows + "\n")
    out = tmp_path / "cli"
    run_cli("analyze", data, "--signal", "x_rad", "--reference", "cart_m", "--time", "t_s",
            "--resample", "--forcing-hz", str(f), "--out", out)
    cli = json.loads((out / "analysis.json").read_text())
    rec = pa.read_record(data, "x_rad", reference="cart_m", time="t_s", resample=True)
    assert rec["resampled"] and rec["notes"], rec["notes"]
    assert rec["sample_rate_hz"] == cli["input"]["sample_rate_hz"]
    got = pa.analyze(rec["signal"], rec["sample_rate_hz"], forcing_hz=f,
                     reference=rec["reference"], start_s=rec["start_s"])
    assert got["zero_one"]["K"] == cli["zero_one"]["K"]
    assert got["phase_sync"]["R"] == cli["phase_sync"]["R"]


def test_a_record_the_cli_refuses_raises_the_same_message(tmp_path):
    data = tmp_path / "bad.csv"
    times = [0.1 * k for k in range(60)]
    times[10] = times[9]
    data.write_text("t_s,x_rad\n" + "".join(f"{t!r},{k}\n" for k, t in enumerate(times)))
    with pytest.raises(ValueError, match="increase strictly"):
        pa.read_record(data, "x_rad", time="t_s")
    with pytest.raises(ValueError, match="no column `y`"):
        pa.read_record(data, "y", sample_rate_hz=10.0)


def test_control_characters_of_a_record_reach_the_message_escaped(tmp_path):
    data = tmp_path / "hostile.csv"
    rows = "".join(f"{0.1 * k!r},{k}\n" for k in range(60))
    data.write_text("t_s,x_rad\n" + rows + "6.0,\x1b]0;owned\x07\x1b[2J\x00\n")
    with pytest.raises(ValueError) as refused:
        pa.read_record(data, "x_rad", time="t_s")
    message = str(refused.value)
    assert "is not a number" in message
    assert not any(c in message for c in "\x1b\x07\x00"), message
    assert "\\u{1b}]0;owned" in message


def test_a_scene_key_cannot_carry_a_value_of_its_own():
    scene = pa.Scene.paper()
    for key in ["beam.segments=5 #", "beam.segments #", "beam..segments", ""]:
        with pytest.raises(pa.SceneError, match="not a scene key"):
            scene.set(key, 3)
    assert scene.set("beam.segments", 3) is not None


def test_a_value_nested_deeper_than_any_key_takes_is_refused_not_a_crash():
    value: list = []
    for _ in range(12_000):
        value = [value]
    with pytest.raises(pa.SceneError, match="levels deep"):
        pa.Scene.default_map().set("map.axes", value)


@pytest.mark.parametrize("clearance", [0.0, float("nan"), -20.0, 200.0, 90.0])
def test_analyze_refuses_a_clearance_outside_zero_to_ninety_degrees(clearance):
    rate = 100.0
    x = np.sin(2 * np.pi * 2.0 * np.arange(2000) / rate)
    with pytest.raises(ValueError, match=r"\(0, 90\) deg"):
        pa.analyze(x, rate, clearance_deg=clearance)


def test_a_map_on_a_machine_without_a_session_prints_no_runtime_folder_error(small_map_file):
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items() if k != "XDG_RUNTIME_DIR"}
    code = (
        "import pendulum_atlas as pa, sys;"
        f"s = pa.Scene.from_toml({str(small_map_file)!r}).set('beam.segments', 2);"
        f"pa.map(s, backend={gpu_backends()[-1]!r}, progress=False)"
    )
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "XDG_RUNTIME_DIR" not in done.stderr, done.stderr


def test_a_cell_of_a_map_runs_with_the_maps_method_and_step(small_map_file):
    scene = pa.Scene.from_toml(small_map_file).set("beam.segments", 2)
    ds = pa.map(scene, backend="cpu", progress=False)
    manifest = json.loads(ds.attrs["map_json"])
    f = float(ds["frequency_hz"][1])
    a = float(ds["amplitude_m"][0])
    cell = scene.cell(frequency_hz=f, amplitude_m=a, run=ds)
    run = json.loads(pa.simulate(cell).attrs["run_json"])
    assert run["method"] == manifest["method"]
    # The map's step: a whole number of steps per forcing period, a multiple of its 16 samples.
    spp = 1.0 / (run["dt_s"] * f)
    assert abs(spp - round(spp)) < 1e-6 and round(spp) % 16 == 0, spp
    assert manifest["dt_s"]["min"] <= run["dt_s"] <= manifest["dt_s"]["max"]


def test_every_cell_reruns_with_the_maps_own_values(small_map_file):
    # The map's own settings of a cell's values (samples_per_period, the early stop off, ...)
    # travel in the cell's [cell]; on the CPU in f64 the rerun is the map's numbers exactly.
    scene = pa.Scene.from_toml(small_map_file).update(SETS)
    ds = pa.map(scene, backend="cpu", precision="f64", progress=False)
    for f in ds.frequency_hz.values:
        for a in ds.amplitude_m.values:
            cell = scene.cell(frequency_hz=float(f), amplitude_m=float(a))
            assert "[cell]" in cell.to_toml()
            values = pa.simulate(cell, progress=False).attrs["map_cell"]
            numbers = [n for n in values if n not in ("regime", "status")]
            assert {"K", "R", "period", "hops"} <= set(numbers), numbers
            for name in numbers:
                want = float(ds[name].sel(frequency_hz=f, amplitude_m=a))
                got = values[name]
                same = np.isnan(want) if got is None else got == want
                assert same, (name, float(f), float(a), got, want)
            attrs = ds["regime"].attrs
            meaning = dict(zip(attrs["flag_values"], attrs["flag_meanings"].split()))
            assert values["regime"] == meaning[int(ds["regime"].sel(frequency_hz=f, amplitude_m=a))]


def test_the_namespace_holds_only_what_it_exports():
    public = {n for n in dir(pa) if not n.startswith("_")}
    exported = {n for n in pa.__all__ if not n.startswith("_")}
    assert public == exported, public ^ exported


def test_a_cell_needs_every_axis_and_a_value_on_its_grid(small_map_file):
    scene = pa.Scene.from_toml(small_map_file)
    with pytest.raises(pa.SceneError, match="excitation.amplitude_m.*needs a value of each axis"):
        scene.cell(frequency_hz=7.5)
    with pytest.raises(pa.SceneError, match="7.6 is not a value of this map's axis"):
        scene.cell(frequency_hz=7.6, amplitude_m=0.009)
    # A value read back from a coordinate (float rounding and all) names its cell.
    cell = scene.cell(frequency_hz=5.0 + 2.5, amplitude_m=0.009 + 0.014)
    assert not cell.is_map


def test_open_run_refuses_arrays_whose_shape_contradicts_map_json(tmp_path, small_map_file):
    out = cli_map(tmp_path, small_map_file, "cpu")
    np.save(out / "K.npy", np.zeros((2, 3)))
    with pytest.raises(ValueError, match=r"K\.npy has shape \(2, 3\), but map.json says \(3, 2\)"):
        pa.open_run(out)


def test_map_takes_its_axes_as_a_keyword(small_map_file):
    scene = pa.Scene.from_toml(small_map_file).update(SETS)
    axes = {"excitation.frequency_hz": (5.0, 10.0, 3), "excitation.amplitude_m": [0.009, 0.023]}
    ds = pa.map(scene, backend="cpu", progress=False, axes=axes)
    assert ds["K"].dims == ("frequency_hz", "amplitude_m")
    np.testing.assert_array_equal(ds["frequency_hz"].values, [5.0, 7.5, 10.0])
    same = pa.map(scene, backend="cpu", progress=False)
    assert ds["K"].values.tobytes() == same["K"].values.tobytes()
    with pytest.raises(TypeError, match="axes takes a dict"):
        pa.map(scene, backend="cpu", progress=False, axes=[("excitation.frequency_hz", [5.0])])


def test_mypy_strict_refuses_options_outside_their_literal_types(tmp_path):
    mypy = pytest.importorskip("mypy.api")
    good = tmp_path / "good.py"
    good.write_text(
        "import pendulum_atlas as pa\n"
        "scene = pa.Scene.default_map()\n"
        "ds = pa.map(scene, backend='cpu', precision='f64', progress=False)\n"
    )
    bad = tmp_path / "bad.py"
    bad.write_text(
        "import pendulum_atlas as pa\n"
        "scene = pa.Scene.default_map()\n"
        "pa.map(scene, backend='cuda')\n"
        "pa.simulate(scene, precision='f16')\n"
        "pa.read_record(42, 'a')\n"
    )
    out, _, status = mypy.run(["--strict", "--no-incremental", str(good)])
    assert status == 0, out
    out, _, status = mypy.run(["--strict", "--no-incremental", str(bad)])
    assert status == 1, out
    assert out.count("error:") >= 3 and "cuda" in out and "f16" in out, out
