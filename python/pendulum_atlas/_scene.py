"""Scenes: a TOML text plus ``key=value`` overrides, checked by the library at every step."""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any, Iterable, Mapping

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

    def cell(self, **coords: float) -> "Scene":
        """One cell of a map scene as a plain scene: the map's base scene with each axis key
        set to the given value, e.g. ``scene.cell(frequency_hz=8.0, amplitude_m=0.02)``
        (an axis by its full key works too: ``**{"excitation.frequency_hz": 8.0}``).

        Every axis needs a value, and each value must be one of its axis's (a value read back
        from the dataset's coordinate is): anything else is not a cell the map ran, and raises
        :class:`pendulum_atlas.SceneError`. The integration method, the step control, the step
        and the row rate the map took for that cell are pinned (``integration.method``,
        ``integration.step``, ``integration.dt_s`` at fixed steps or
        ``integration.base_step_s`` at adaptive ones, ``output.sample_rate_hz``), as the
        explorer pins them, so that :func:`pendulum_atlas.simulate` runs what the map ran. A
        cell of a plain map that does not settle (``map.settle = false``, or a map that
        cannot) also carries the map's settings of a cell's values (a ``[cell]`` section):
        :func:`pendulum_atlas.simulate` then gives, in ``attrs["map_cell"]``, the cell's
        values as the map computes them (on the CPU in f64: the map's own numbers, bit for
        bit, where the map ran there). A settling map's cell has none: whether the map ran it
        on depends on its run (the explorer's download of the cell carries it)."""
        if not self.is_map:
            raise ValueError("cell() takes a map scene (one with a [map] section)")
        single = Scene(self._base, f"{self._origin} (a cell of the map)")
        for name, value in coords.items():
            single.set(_full_key(name, self._resolved), value)
        pins = _native.cell_pins(self._text, self._origin, list(self._sets), list(single._sets))
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
            f"cell(): `{name}` is not the short name of one axis of this map (axes: {', '.join(axes)}); "
            "give other keys in full, e.g. **{'excitation.frequency_hz': 8.0}"
        )
    return found[0]
