"""Maps and runs as ``xarray.Dataset``: one builder for maps run here and map folders."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
import xarray as xr

from . import _native

#: The folder inside an output folder that holds an earlier run's files while a ``--force``
#: run replaces them (``EARLIER_DIR`` of ``crates/map/src/output/earlier.rs``).
EARLIER_DIR = ".pendulum-atlas.earlier"

#: Scalars of ``map.json`` copied into a map dataset's attributes (the whole manifest is in
#: ``attrs["map_json"]``).
MAP_ATTRS = ("backend", "adapter", "precision", "segments", "method", "instances")


def dim_names(keys: list[str]) -> list[str]:
    """Dimension names of a map's axes: the key's last part (``frequency_hz``) when the axes'
    last parts differ, else the full key."""
    short = [k.rsplit(".", 1)[-1] for k in keys]
    return short if len(set(short)) == len(short) else list(keys)


def _codes_attrs(codes: Mapping[str, int]) -> dict:
    """CF flag attributes for a coded variable (``regime``, ``status``)."""
    ordered = sorted(codes.items(), key=lambda kv: kv[1])
    return {
        "flag_values": [int(v) for _, v in ordered],
        "flag_meanings": " ".join(name for name, _ in ordered),
    }


def map_dataset(
    manifest: dict, arrays: Mapping[str, np.ndarray], bifurcations: dict | None = None
) -> xr.Dataset:
    """A map's dataset from its ``map.json`` content and its arrays (``.npy`` stems); with the
    orbit stage, ``bifurcations.json``'s content (its curves in ``attrs["bifurcations_json"]``,
    a list per curve of ``kind``, ``families``, ``period``, ``points`` in axis values, ``tol``)."""
    axes = manifest["axes"]
    dims = dim_names([a["key"] for a in axes])
    coords = {}
    for i, (dim, axis) in enumerate(zip(dims, axes)):
        values = arrays.get(f"axis{i}")
        if values is None:
            values = np.asarray(axis["values"], dtype=np.float64)
        attrs = {"key": axis["key"], "scale": axis["scale"], "units": axis.get("unit") or "1"}
        if axis.get("label"):
            attrs["long_name"] = axis["label"]
        coords[dim] = (dim, values, attrs)
    units = manifest.get("units", {})
    descriptions = manifest.get("descriptions", {})
    data_vars = {}
    for name, values in arrays.items():
        if name.startswith("axis"):
            continue
        attrs = {}
        # A map run both ways has the second direction's arrays as NAME_down.
        base = name.removesuffix("_down")
        if base in units:
            attrs["units"] = units[base]
        if base in descriptions:
            attrs["long_name"] = descriptions[base]
        if base == "regime" and manifest.get("regime"):
            attrs.update(_codes_attrs(manifest["regime"]["codes"]))
        elif base == "status" and "status_codes" in manifest:
            attrs.update(_codes_attrs(manifest["status_codes"]))
        elif name == "orbit_status" and manifest.get("orbits"):
            attrs.update(_codes_attrs(manifest["orbits"]["status_codes"]))
        elif name in ("transient_s", "transient_se_s", "start_sensitivity") and manifest.get("transients"):
            attrs["long_name"] = manifest["transients"]["arrays"][name]
            attrs["units"] = "1" if name == "start_sensitivity" else "s"
        elif name == "inferred":
            attrs.update({"flag_values": [0, 1], "flag_meanings": "computed filled_from_its_block"})
        elif name == "hysteresis":
            attrs.update({"flag_values": [0, 1], "flag_meanings": "up_and_down_agree up_and_down_differ"})
        # basin_fraction has one leading axis more: the attractor label.
        var_dims = ("attractor_label", *dims) if values.ndim == len(dims) + 1 else dims
        data_vars[name] = (var_dims, values, attrs)
    attrs = {k: manifest[k] for k in MAP_ATTRS if manifest.get(k) is not None}
    attrs["map_json"] = json.dumps(manifest)
    if bifurcations is not None:
        attrs["bifurcations_json"] = json.dumps(bifurcations)
    return xr.Dataset(data_vars, coords, attrs)


def run_dataset(
    columns: Mapping[str, np.ndarray], units: Mapping[str, str], report: dict, notes: Sequence[str] = ()
) -> xr.Dataset:
    """A single run's dataset: one variable per trajectory column over ``time`` (s), the
    run's ``run.json`` in ``attrs["run_json"]`` and its indicators as attributes; for a map
    cell, ``attrs["map_cell"]``: the cell's values as its map computes them; where there are
    any, ``attrs["warnings"]``: the scene's ``notes`` and the run's warnings."""
    time = columns["t_s"]
    data_vars = {
        name: ("time", values, {"units": units[name]})
        for name, values in columns.items()
        if name != "t_s"
    }
    coords = {"time": ("time", time, {"units": "s", "long_name": "time"})}
    attrs = {
        "status": report["status"],
        "integrator": report["integrator"],
        "precision": report["precision"],
        "method": report["method"],
        "dt_s": report["dt_s"],
        "impacts": report["impacts"],
    }
    attrs.update(_indicators(report))
    if "map_cell" in report:
        # A map cell: its values as its map computes them (name -> number or code name).
        attrs["map_cell"] = report["map_cell"]["values"]
    said = [*notes, *report.get("warnings", [])]
    if said:
        attrs["warnings"] = said
    attrs["run_json"] = json.dumps(report)
    return xr.Dataset(data_vars, coords, attrs)


def _indicators(report: dict) -> dict:
    """λ1 and the paper's indicators of a run, where it has them."""
    out = {}
    lyap = report.get("lyapunov") or {}
    if "per_s" in lyap:
        out["lambda1_per_s"] = lyap["per_s"]
        out["lambda1_se_per_s"] = lyap["se_per_s"]
    analysis = report.get("analysis") or {}
    picks = {
        "K": ("zero_one", "K"),
        "R": ("phase_sync", "R"),
        "dominant_hz": ("spectrum", "dominant_hz"),
        "line_ratio": ("spectrum", "ratio_to_forcing"),
        "period": ("statistics", "period"),
        "hops": ("statistics", "hops"),
    }
    for attr, (section, key) in picks.items():
        value = (analysis.get(section) or {}).get(key)
        if value is not None:
            out[attr] = value
    return out


def open_run(folder: str | os.PathLike) -> xr.Dataset:
    """The dataset of a ``pendulum-atlas map`` or ``merge`` output folder: every array its
    ``map.json`` lists, with the axes as coordinates."""
    folder = Path(folder)
    manifest_path = folder / "map.json"
    shown = _native.printable(str(folder))
    if not manifest_path.is_file():
        if (folder / "shard.json").is_file():
            raise ValueError(f"{shown} holds one shard of a map: merge the shards first (`pendulum-atlas merge`)")
        if (folder / EARLIER_DIR / "map.json").is_file():
            raise FileNotFoundError(
                f"{shown} has no map.json: a run that replaced the map in it (`--force`) was stopped before it "
                f"completed, and the earlier complete map is set aside in {shown}/{EARLIER_DIR}; the next "
                "`pendulum-atlas map` (or `merge`) into the folder puts it back first, or move its files back "
                "into the folder to open it now"
            )
        raise FileNotFoundError(
            f"{shown} has no map.json: open_run reads the output folder of `pendulum-atlas map` or `merge`"
        )
    # Read and checked by the type the command writes it with: a damaged map.json, or one
    # listing a path outside the folder, raises ValueError naming the problem.
    manifest = _native.read_map_manifest(str(manifest_path))
    arrays = {}
    for name in manifest.get("files", []):
        if name.endswith(".npy"):
            arrays[name[: -len(".npy")]] = np.load(folder / name, allow_pickle=False)
    _check_shapes(folder, manifest, arrays)
    bifurcations = None
    if "bifurcations.json" in manifest.get("files", []):
        bifurcations = json.loads((folder / "bifurcations.json").read_text(encoding="utf-8"))
    return map_dataset(manifest, arrays, bifurcations)


def _check_shapes(folder: Path, manifest: dict, arrays: Mapping[str, np.ndarray]) -> None:
    """Every array of a map folder shaped as its ``map.json`` says: the grid's shape (with one
    leading axis more for the per-label arrays), and each axis as long as the grid along it."""
    shape = tuple(manifest["shape"])
    for name, values in arrays.items():
        if name.startswith("axis") and name[4:].isdigit():
            i = int(name[4:])
            ok = i < len(shape) and values.shape == (shape[i],)
            want = f"({shape[i]},)" if i < len(shape) else "no such axis"
        else:
            ok = values.shape == shape or values.shape[1:] == shape
            want = f"{shape} (or one leading axis more)"
        if not ok:
            raise ValueError(
                f"{folder / (name + '.npy')} has shape {values.shape}, but map.json says {want}: "
                "the folder was altered or mixes two maps; run the map again"
            )
