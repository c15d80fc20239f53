"""pendulum-atlas from Python: chaos and bifurcation maps of the elastic inverted pendulum
with clearance, single runs, and the paper's indicators for measured records.

Thin over the Rust library (``pendulum_atlas._native``): the same scenes, engines and numbers
as the ``pendulum-atlas`` command, returned as ``xarray`` datasets.

>>> import pendulum_atlas as pa
>>> scene = pa.Scene.default_map().set("map.axes", ...)   # doctest: +SKIP
>>> ds = pa.map(scene)                                      # doctest: +SKIP
"""

import numbers as _numbers
import os as _os
import tempfile as _tempfile
import typing as _t
import warnings as _warnings

import numpy as _np
import xarray as _xr

#: Where a map or run integrates: a hardware GPU, else lavapipe or the CPU, whichever is
#: faster (``"auto"``); any wgpu adapter (``"gpu"``); the CPU engine (``"cpu"``).
Backend = _t.Literal["auto", "gpu", "cpu"]
#: The float type: single precision, as the GPU integrates, or double.
Precision = _t.Literal["f32", "f64"]
#: A single run's integrator: the maps' engine, or the DOP853 reference (f64).
Integrator = _t.Literal["engine", "reference"]
#: The 0-1 test's samples of a record.
Sampling = _t.Literal["stroboscopic", "extrema", "uniform"]


def _quiet_headless_vulkan() -> None:
    """Give the Vulkan loader a runtime folder where the session has none (a server, a
    container), as the command does: without one it prints "error: XDG_RUNTIME_DIR is invalid
    or not set" on every map, which is no error of the user's."""
    if _os.environ.get("XDG_RUNTIME_DIR"):
        return
    user = _os.environ.get("USER", "user")
    folder = _os.path.join(_tempfile.gettempdir(), f"pendulum-atlas-runtime-{user}")
    try:
        _os.makedirs(folder, mode=0o700, exist_ok=True)
    except OSError:
        return
    _os.environ["XDG_RUNTIME_DIR"] = folder


_quiet_headless_vulkan()

from . import _native  # noqa: E402  (after the runtime folder is set)
from ._dataset import map_dataset as _map_dataset  # noqa: E402
from ._dataset import open_run  # noqa: E402
from ._dataset import run_dataset as _run_dataset  # noqa: E402
from ._scene import Scene  # noqa: E402

__version__ = _native.__version__
SceneError = _native.SceneError
EngineError = _native.EngineError

__all__ = [
    "Scene",
    "SceneError",
    "EngineError",
    "Backend",
    "Precision",
    "Integrator",
    "Sampling",
    "map",
    "simulate",
    "analyze",
    "read_record",
    "open_run",
    "__version__",
]


def map(
    scene: Scene,
    backend: Backend = "auto",
    precision: Precision | None = None,
    progress: bool = True,
    axes: _t.Mapping[str, _t.Sequence[float] | tuple[float, float, int]] | None = None,
) -> _xr.Dataset:
    """Run a map scene on the GPU or the CPU engine and return its dataset.

    Dimensions and coordinates are the map's axes (units in each coordinate's ``attrs``); one
    variable per stored metric (``K``, ``R``, ``period``, ..., ``lyapunov``,
    ``regime_confidence``, ``verdict_confidence``), ``regime`` (int8 codes, meanings in its ``flag_meanings``),
    ``status`` and, for refined maps, ``inferred``. The values equal the ``.npy`` files of
    ``pendulum-atlas map`` for the same scene bit for bit; ``attrs["map_json"]`` holds the
    ``map.json`` the command would write (without its file list).

    ``backend``: ``"auto"`` (a hardware GPU, else lavapipe or the CPU, whichever is faster),
    ``"gpu"`` or ``"cpu"``. ``precision``: ``None`` (f32 on the GPU, f64 on the CPU),
    ``"f32"`` or ``"f64"``. ``progress``: a tqdm bar (terminal or Jupyter). The interpreter's
    lock is released while the engine runs; Ctrl-C stops the map at its next progress point
    and raises ``KeyboardInterrupt``.

    ``axes``: the map's axes in place of the scene's ``map.axes``, key → values (a list or
    an array), or key → ``(start, end, count)`` (a tuple of three is always a range; its count
    a whole number of any numeric type, ``13``, ``numpy.int64(13)`` or ``13.0``), in grid
    order, e.g.
    ``axes={"excitation.frequency_hz": (4.0, 12.0, 33), "excitation.amplitude_m": [0.01, 0.02]}``.
    """
    if not isinstance(scene, Scene):
        raise TypeError(f"map() takes a pendulum_atlas.Scene, not {type(scene).__name__}")
    if axes is not None:
        scene = scene.copy().set("map.axes", _axes_list(axes))
    if not scene.is_map:
        raise SceneError(
            "this scene has no [map] section: map() runs a map scene (see Scene.default_map()); "
            "use simulate() for one run"
        )
    with _Bar(progress, "map") as bar:
        out = _native.run_map_scene(
            scene.text, scene.origin, scene.sets, backend, precision, bar.update
        )
    return _map_dataset(out["manifest"], out["arrays"], out.get("bifurcations"))


def _axes_list(axes: _t.Mapping[str, _t.Any]) -> list[dict[str, _t.Any]]:
    """``map.axes`` from ``{key: values}`` or ``{key: (start, end, count)}``: a tuple of three
    is always a range, its count a whole number of any numeric type (``13``,
    ``numpy.int64(13)``, ``13.0``); values are given as a list (or an array)."""
    if not isinstance(axes, _t.Mapping) or not axes:
        raise TypeError("axes takes a dict of one to three keys: key -> values, or key -> (start, end, count)")
    out = []
    for key, spec in axes.items():
        if isinstance(spec, tuple) and len(spec) == 3:
            start, end, count = spec
            out.append({"key": key, "start": float(start), "end": float(end), "count": _count(key, count)})
        else:
            values = [float(v) for v in _np.asarray(spec, dtype=float).ravel()]
            out.append({"key": key, "values": values})
    return out


def _count(key: str, count: _t.Any) -> int:
    """The count of a ``(start, end, count)`` axis as an int: an integral number of any type
    (a bool is not one); anything else is refused."""
    if isinstance(count, (bool, _np.bool_)):
        raise TypeError(
            _native.printable(f"axes[{key!r}]: the count of (start, end, count) is a whole number, not {count!r}")
        )
    if isinstance(count, (_numbers.Integral, _np.integer)):
        return int(count)
    if isinstance(count, (_numbers.Real, _np.floating)) and float(count).is_integer():
        return int(float(count))
    raise ValueError(
        _native.printable(
            f"axes[{key!r}]: the count of (start, end, count) is a whole number of cells, got {count!r}; "
            "give the axis' values as a list to sweep those values"
        )
    )


def simulate(
    scene: Scene,
    integrator: Integrator = "engine",
    precision: Precision | None = None,
    progress: bool = True,
) -> _xr.Dataset:
    """Integrate one scene and return its trajectory over ``time`` (s).

    Variables are the columns of ``simulate``'s ``trajectory.csv`` (``x0_m``, ``alpha_rad``,
    ..., units in their ``attrs``); λ1 and the paper's indicators of the run (``K``, ``R``,
    ``dominant_hz``, ``line_ratio``, ``period``, ``hops``) are attributes, and
    ``attrs["run_json"]`` holds the ``run.json`` the command would write. A cell of a map
    (:meth:`Scene.cell`) has ``attrs["map_cell"]``: its values as its map computes them.
    What the command prints as warnings (the scene's notes, the run's warnings) is in
    ``attrs["warnings"]`` where there are any; the scene's notes are also issued as
    ``UserWarning``, among them that a settling map's cell made without its run's
    ``ran_on`` cannot be rerun as its map computed it (it then has no ``map_cell``).

    ``integrator``: ``"engine"`` (the maps' stepper: RK4 or IMEX, adaptive or fixed) or ``"reference"``
    (adaptive DOP853, f64). ``precision``: ``None`` (f64), ``"f32"`` or ``"f64"``. Ctrl-C
    stops the run at its next output row and raises ``KeyboardInterrupt``.
    """
    if not isinstance(scene, Scene):
        raise TypeError(f"simulate() takes a pendulum_atlas.Scene, not {type(scene).__name__}")
    with _Bar(progress, "simulate") as bar:
        out = _native.run_single_scene(
            scene.text, scene.origin, scene.sets, integrator, precision, bar.update
        )
    # What the command prints as warnings on reading the scene (keys given but not used, a
    # settling map's cell without its run's ran_on).
    for note in out["notes"]:
        _warnings.warn(note, UserWarning, stacklevel=2)
    return _run_dataset(out["columns"], out["units"], out["report"], out["notes"])


def analyze(
    signal: _t.Any,
    sample_rate_hz: float,
    forcing_hz: float | None = None,
    reference: _t.Any = None,
    transient_s: float = 0.0,
    start_s: float = 0.0,
    clearance_deg: float | None = None,
    sampling: Sampling | None = None,
) -> dict[str, _t.Any]:
    """The paper's indicators of a uniformly sampled record, as ``analyze`` computes them for
    a CSV (``docs/analysis.md``).

    ``signal``: the response (e.g. the holder angle), one value per sample at
    ``sample_rate_hz``. ``forcing_hz`` enables stroboscopic sampling, the period and the
    line ratio; ``reference`` (the excitation, same length) enables R; ``transient_s`` is
    discarded from the start; ``clearance_deg`` counts hops between the wells; ``sampling``
    picks the 0–1 test's samples (``None``: stroboscopic with ``forcing_hz``, else the local
    extrema; or ``"stroboscopic"``, ``"extrema"``, ``"uniform"``). The defaults are those of
    ``pendulum-atlas analyze``.

    Returns a dict with ``zero_one`` (``K``), ``phase_sync`` (``R``), ``spectrum``,
    ``statistics`` (period, hops, range), ``wavelet`` and the options used. A record the
    analysis refuses raises ``ValueError`` with the reason.
    """
    x = _np.ascontiguousarray(signal, dtype=_np.float64)
    if x.ndim != 1:
        raise ValueError(f"signal must be one-dimensional, got shape {x.shape}")
    ref = None
    if reference is not None:
        ref = _np.ascontiguousarray(reference, dtype=_np.float64)
        if ref.shape != x.shape:
            raise ValueError(f"reference has shape {ref.shape}, the signal {x.shape}: give one value per sample")
    return _native.analyze_signal(
        x,
        float(sample_rate_hz),
        forcing_hz,
        ref,
        float(transient_s),
        float(start_s),
        clearance_deg,
        sampling,
    )


class _Bar:
    """A tqdm bar moved by the engine's progress (or nothing when ``enabled`` is false)."""

    def __init__(self, enabled: bool, what: str):
        self._bar = None
        if enabled:
            from tqdm.auto import tqdm

            self._bar = tqdm(total=1, desc=what, unit="", leave=False, mininterval=0.5)

    def update(self, done: int, total: int, unit: str) -> None:
        if self._bar is None or total == 0:
            return
        if self._bar.total != total:
            self._bar.total = total
            self._bar.unit = f" {unit}"
        self._bar.update(done - self._bar.n)

    def __enter__(self) -> "_Bar":
        return self

    def __exit__(self, *exc: object) -> None:
        if self._bar is not None:
            self._bar.close()


def read_record(
    path: str | _os.PathLike[str],
    signal: str,
    reference: str | None = None,
    time: str | None = None,
    time_unit: str = "s",
    sample_rate_hz: float | None = None,
    resample: bool = False,
    allow_gaps: bool = False,
) -> dict[str, _t.Any]:
    """A measured CSV record read exactly as ``pendulum-atlas analyze`` reads it: the columns
    ``signal`` (and ``reference``) on a uniform grid, from the ``time`` column (resampled
    linearly at its median rate with ``resample=True``; gaps refused unless ``allow_gaps``) or
    at ``sample_rate_hz``.

    Returns a dict with ``signal`` and ``reference`` (NumPy arrays; ``reference`` may be
    ``None``), ``sample_rate_hz``, ``start_s``, ``resampled``, and the ``notes`` and
    ``warnings`` the command would print. Pass them on to :func:`analyze`. A file the command
    refuses raises ``ValueError`` with the same message.
    """
    if not isinstance(path, (str, _os.PathLike)):
        raise TypeError(f"read_record() takes a path, not {type(path).__name__}")
    return _native.read_record(
        _os.fspath(path), signal, reference, time, time_unit, sample_rate_hz, resample, allow_gaps
    )
