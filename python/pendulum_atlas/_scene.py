"""Scenes: a TOML text plus ``key=value`` overrides, checked by the library at every step."""

from __future__ import annotations

import os
import sys
import warnings
from pathlib import Path
from typing import Any, Iterable, Mapping

import numpy as np

from . import _native

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib


class Scene:
    """A scene or a map scene: its TOML text and the overrides applied to it.

    The overrides are the command line's ``--set key=value`` arguments, in order
    (:attr:`sets`), so ``pendulum-atlas map FILE --set ...`` runs the same scene. Every
    change is validated by the library at once: a refused key or value raises
    :class:`pendulum_atlas.SceneError` with the library's message (the key and the accepted
    range).
    """

    def __init__(self, text: str, origin: str = "<text>", sets: Iterable[str] = ()):
        self._text = text
        self._origin = origin
        self._sets = list(sets)
        self._check()

    # -- construction -------------------------------------------------------------------
    @classmethod
    def from_toml(cls, source: str | os.PathLike) -> "Scene":
        """A scene from a TOML file (a path) or from TOML text.

        A string is read as a path when it names an existing file, else as TOML text.
        """
        if isinstance(source, os.PathLike) or _names_file(source):
            path = Path(source)
            return cls(path.read_text(encoding="utf-8"), str(path))
        if not isinstance(source, str):
            raise TypeError(f"Scene.from_toml takes a path or TOML text, not {type(source).__name__}")
        if source.strip().endswith(".toml") and "\n" not in source and "=" not in source:
            raise FileNotFoundError(f"no scene file {source!r} (TOML text has at least one `key = value`)")
        return cls(source, "<text>")

    @classmethod
    def default_map(cls) -> "Scene":
        """The embedded default map (``configs/maps/default.toml``): K, R, λ1 and the regime
        over forcing frequency × cart amplitude."""
        return cls(_native.DEFAULT_MAP_TOML, "configs/maps/default.toml")

    @classmethod
    def paper(cls) -> "Scene":
        """The paper's scene (``configs/paper.toml``), one run."""
        return cls(_native.PAPER_SCENE_TOML, "configs/paper.toml")

    # -- changes ------------------------------------------------------------------------
    def set(self, key: str, value: Any) -> "Scene":
        """Override ``key`` (a dotted scene key, e.g. ``"beam.segments"`` or
        ``"map.axes"``) with ``value`` (bool, int, float, str or a list of them). Returns the
        scene, so calls chain. A refused value leaves the scene as it was."""
        arg = _native.set_arg(key, value)
        self._sets.append(arg)
        try:
            self._check()
        except Exception:
            self._sets.pop()
            raise
        return self

    def update(self, values: Mapping[str, Any]) -> "Scene":
        """:meth:`set` for every item of ``values``, in order."""
        for key, value in values.items():
            self.set(key, value)
        return self

    def copy(self) -> "Scene":
        """An independent copy."""
        return Scene(self._text, self._origin, self._sets)

    def cell(
        self,
        *,
        run: Any = None,
        ran_on: bool | None = None,
        copies: bool | None = None,
        **coords: float,
    ) -> "Scene":
        """One cell of a map scene as a plain scene: the map's base scene with each axis key
        set to the cell's value, e.g. ``scene.cell(frequency_hz=8.0, amplitude_m=0.02)``
        (an axis by its full key works too: ``**{"excitation.frequency_hz": 8.0}``).

        Every axis needs a value, and each value must be one of its axis's: a value within
        ``1e-9`` of a grid value's magnitude (one read back from the dataset's coordinate,
        or computed as ``start + i * step``) names that grid value, and the cell runs the grid
        value exactly (a ``UserWarning`` names the key, the value given and the grid value
        where they differ); anything else is not a cell the map ran, and raises
        :class:`pendulum_atlas.SceneError` naming the key and the nearest grid values. The
        integration method, the step control, the step and the row rate the map took for
        that cell are pinned (``integration.method``, ``integration.step``,
        ``integration.dt_s`` at fixed steps or ``integration.base_step_s`` at adaptive ones,
        ``output.sample_rate_hz``), as the explorer pins them, so that
        :func:`pendulum_atlas.simulate` runs what the map ran.

        A cell of a plain map also carries the map's settings of a cell's values (a
        ``[cell]`` section): :func:`pendulum_atlas.simulate` then gives, in
        ``attrs["map_cell"]``, the cell's values as the map computes them (on the CPU in
        f64: the map's own numbers, bit for bit, where the map ran there). A map that settles
        (the default) ran some cells on past its length, which only its run knows: give the
        map's dataset as ``run`` (what :func:`pendulum_atlas.map` returned for this scene, or
        :func:`pendulum_atlas.open_run` of its folder), and the cell is the one the explorer
        downloads (its ``ran_on``, the map's method and, with ``map.initial_states``, the
        start the map kept for it, and whether it ran the cell's nudged copies); or say
        ``ran_on=True`` or ``False`` yourself (and ``copies=True`` where the map's
        ``start_sensitivity`` of the cell is a number: it ran the cell's copies). Without
        either, a settling map's cell has no map values: :func:`pendulum_atlas.simulate`
        and the command's ``simulate`` warn that it cannot be rerun as its map computed it.
        """
        if not self.is_map:
            raise ValueError("cell() takes a map scene (one with a [map] section)")
        if run is not None and (ran_on is not None or copies is not None):
            raise TypeError("cell(): give the map's run (run=dataset) or ran_on and copies, not both")
        for name, flag in (("ran_on", ran_on), ("copies", copies)):
            if flag is not None and not isinstance(flag, (bool, np.bool_)):
                raise TypeError(f"cell(): {name} is True or False, not {type(flag).__name__}")
        given: dict[str, Any] = {}
        for name, value in coords.items():
            key = _full_key(name, self._resolved)
            if key in given:
                raise ValueError(f"cell(): {_native.printable(key)} is given twice")
            given[key] = value
        cell_sets = [_native.set_arg(key, value) for key, value in given.items()]
        at = _native.cell_at(self._text, self._origin, list(self._sets), cell_sets)
        for key, value_given, grid in at["snapped"]:
            warnings.warn(
                f"cell(): {key} = {value_given!r} is within {at['tolerance']:g} (relative) of the map's grid "
                f"value {grid!r}: the cell runs {grid!r}",
                UserWarning,
                stacklevel=2,
            )
        grid_values = at["values"]
        others = [s for key, s in zip(given, cell_sets) if key not in grid_values]
        method = start = None
        if run is not None:
            ran_on, method, start, copies = _cell_of_run(run, at)
        pins = _native.cell_pins(
            self._text,
            self._origin,
            list(self._sets),
            at["index"],
            others,
            method,
            None if ran_on is None else bool(ran_on),
            start,
            None if copies is None else bool(copies),
        )
        single = Scene(self._base, f"{self._origin} (a cell of the map)")
        for key, value in given.items():
            single.set(key, grid_values.get(key, value))
        return single.update(pins)

    # -- what it is ---------------------------------------------------------------------
    @property
    def is_map(self) -> bool:
        """Whether the scene has a ``[map]`` section (runs with :func:`pendulum_atlas.map`)."""
        return self._kind == "map"

    @property
    def sets(self) -> list[str]:
        """The overrides, as ``--set`` arguments of the command line."""
        return list(self._sets)

    @property
    def origin(self) -> str:
        """Where the text came from (a path, or ``<text>``)."""
        return self._origin

    @property
    def text(self) -> str:
        """The TOML text the scene was made from, before the overrides."""
        return self._text

    def to_toml(self) -> str:
        """The whole scene after the overrides, as TOML (what ``map_scene.toml`` holds)."""
        return self._resolved

    def cli_args(self) -> list[str]:
        """``--set`` arguments that give this scene on the command line."""
        return [part for s in self._sets for part in ("--set", s)]

    def __repr__(self) -> str:
        kind = "map scene" if self.is_map else "scene"
        return f"<pendulum_atlas.Scene: {kind} from {self._origin}, {len(self._sets)} override(s)>"

    def _check(self) -> None:
        self._kind, self._resolved, self._base = _native.check_scene(
            self._text, self._origin, self._sets
        )


def _names_file(source: Any) -> bool:
    return isinstance(source, str) and "\n" not in source and len(source) < 4096 and Path(source).is_file()


def _full_key(name: str, map_toml: str) -> str:
    """``frequency_hz`` → ``excitation.frequency_hz``: a short name is that of one of the
    map's axes; any other key is given in full."""
    if "." in name:
        return name
    axes = [a["key"] for a in tomllib.loads(map_toml).get("map", {}).get("axes", [])]
    found = [k for k in axes if k.rsplit(".", 1)[-1] == name]
    if len(found) != 1:
        raise ValueError(
            _native.printable(
                f"cell(): `{name}` is not the short name of one axis of this map (axes: {', '.join(axes)}); "
                "give other keys in full, e.g. **{'excitation.frequency_hz': 8.0}"
            )
        )
    return found[0]


def _cell_of_run(
    run: Any, at: Mapping[str, Any]
) -> tuple[bool | None, str | None, int | None, bool | None]:
    """What the map's run ``run`` (its dataset) says of the cell ``at`` (``_native.cell_at``):
    whether it ran the cell on (``ran_on``; ``None`` where the map does not settle), its
    integration method, the start it kept for the cell (with ``map.initial_states``), and
    whether it ran the cell's nudged copies (``None`` where it runs none)."""
    from ._dataset import dim_names

    if not hasattr(run, "data_vars") or not hasattr(run, "attrs"):
        raise TypeError(
            f"cell(): run takes the map's dataset (from pendulum_atlas.map or open_run), not {type(run).__name__}"
        )
    keys = [key for key, _ in at["axes"]]
    dims = dim_names(keys)
    for dim, (key, values) in zip(dims, at["axes"]):
        if dim not in run.coords or not np.array_equal(np.asarray(run[dim].values, dtype=float), values):
            raise _native.SceneError(
                _native.printable(
                    f"cell(): the run's dataset has not this map's axis {key} ({len(values)} values from "
                    f"{values[0]!r} to {values[-1]!r}): give the dataset of this scene's map"
                )
            )
    k = at["index"]

    def at_cell(name: str) -> Any:
        return run[name].transpose(*dims).values.reshape(-1)[k]

    ran_on = None
    if at["settles"]:
        if "ran_on" not in run.data_vars:
            raise _native.SceneError(
                "cell(): this map settles, and its dataset has no ran_on (which cells the map ran on); "
                "open the map's folder with open_run, or give ran_on=True or False"
            )
        ran_on = bool(at_cell("ran_on") == 1)
    start = int(at_cell("start")) if at["starts"] > 1 and "start" in run.data_vars else None
    if start is not None and not 0 <= start < at["starts"]:
        raise _native.SceneError(
            f"cell(): the run's start.npy says start {start} for this cell, and the map has {at['starts']} starts "
            "per cell: the dataset is of another map"
        )
    method = run.attrs.get("method")
    # The map ran the cell's nudged copies where its start sensitivity is known.
    copies = None
    if "start_sensitivity" in run.data_vars:
        copies = bool(np.isfinite(at_cell("start_sensitivity")))
    return ran_on, method if isinstance(method, str) else None, start, copies
