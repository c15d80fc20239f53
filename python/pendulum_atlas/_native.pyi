"""Type stubs of the Rust extension ``pendulum_atlas._native`` (``python/src/lib.rs``).

Users call the package's functions (``pendulum_atlas.map``, ``simulate``, ``analyze``), which
convert what these return into xarray datasets and dicts.
"""

from typing import Any, Callable, Literal, Optional, TypedDict

import numpy as np
import numpy.typing as npt

__version__: str
DEFAULT_MAP_TOML: str
PAPER_SCENE_TOML: str

class SceneError(ValueError):
    """A scene the library refuses: the message names the key and its accepted range."""

class EngineError(RuntimeError):
    """A run that could not be made (no adapter, too large, a failed device)."""

Progress = Callable[[int, int, str], None]

class MapResult(TypedDict):
    arrays: dict[str, npt.NDArray[np.generic]]
    manifest: dict[str, Any]
    bifurcations: Optional[dict[str, Any]]

class RunResult(TypedDict):
    columns: dict[str, npt.NDArray[np.float64]]
    units: dict[str, str]
    report: dict[str, Any]
    notes: list[str]

def set_arg(key: str, value: object) -> str:
    """``key=value`` with the value written as TOML (a ``--set`` argument)."""

def check_scene(text: str, origin: str, sets: list[str]) -> tuple[Literal["map", "scene"], str, str]:
    """Validate a scene: its kind, its TOML after the overrides, and its base scene's TOML."""

def run_map_scene(
    text: str,
    origin: str,
    sets: list[str],
    backend: Literal["auto", "gpu", "cpu"] = "auto",
    precision: Optional[Literal["f32", "f64"]] = None,
    progress: Optional[Progress] = None,
) -> MapResult:
    """Run a map scene: its arrays by name, ``map.json`` (without its file list) and, with the
    orbit stage, ``bifurcations.json``."""

def run_single_scene(
    text: str,
    origin: str,
    sets: list[str],
    integrator: Literal["engine", "reference"] = "engine",
    precision: Optional[Literal["f32", "f64"]] = None,
    progress: Optional[Progress] = None,
) -> RunResult:
    """Integrate one scene: its columns, their units and ``run.json`` as a dict."""

def analyze_signal(
    signal: npt.NDArray[np.float64],
    sample_rate_hz: float,
    forcing_hz: Optional[float] = None,
    reference: Optional[npt.NDArray[np.float64]] = None,
    transient_s: float = 0.0,
    start_s: float = 0.0,
    clearance_deg: Optional[float] = None,
    sampling: Optional[Literal["stroboscopic", "extrema", "uniform"]] = None,
) -> dict[str, Any]:
    """The paper's indicators of a record, as ``analyze`` writes them to ``analysis.json``."""

class RecordResult(TypedDict):
    signal: npt.NDArray[np.float64]
    reference: Optional[npt.NDArray[np.float64]]
    sample_rate_hz: float
    start_s: float
    resampled: bool
    notes: list[str]
    warnings: list[str]

def read_record(
    path: str,
    signal: str,
    reference: Optional[str] = None,
    time: Optional[str] = None,
    time_unit: str = "s",
    sample_rate_hz: Optional[float] = None,
    resample: bool = False,
    allow_gaps: bool = False,
) -> RecordResult:
    """A measured CSV record read as ``pendulum-atlas analyze`` reads it, on a uniform grid."""

class CellAt(TypedDict):
    index: int
    values: dict[str, float]
    snapped: list[tuple[str, float, float]]
    tolerance: float
    axes: list[tuple[str, list[float]]]
    settles: bool
    starts: int

def cell_at(text: str, origin: str, sets: list[str], cell_sets: list[str]) -> CellAt:
    """The cell of a map that ``key=value`` arguments name (every axis given, each within
    ``tolerance`` of its grid): its index, its grid values, the values snapped to them."""

def cell_pins(
    text: str,
    origin: str,
    sets: list[str],
    index: int,
    others: list[str],
    method: Optional[str] = None,
    ran_on: Optional[bool] = None,
    start: Optional[int] = None,
    copies: Optional[bool] = None,
) -> dict[str, Any]:
    """The method, step control, step and row rate a map took for cell ``index``, as scene
    keys and values, and a plain map's ``[cell]`` section (``cell``), as the explorer's
    download of the cell has them."""

def printable(s: str) -> str:
    """``s`` with its control characters and bidirectional overrides written as escapes."""

def read_map_manifest(path: str) -> dict[str, Any]:
    """A map folder's ``map.json``, read and checked (fields, files by name only), as a dict."""

def result_fields() -> list[dict[str, Any]]:
    """The result schema: one dict per result a map can store (name, unit, dtype,
    description, metric)."""
    ...
