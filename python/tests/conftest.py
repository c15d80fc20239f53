"""Shared pieces of the package's tests: the command-line binary to compare against, and
small scenes (small grids, N = 3, short runs)."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]

#: A 3 × 2 map of the default plane, every metric of the default map and the line.
SMALL_MAP = """
[beam]
segments = 3

[integration]
duration_s = 25.0
transient_s = 5.0

[map]
metrics = ["K", "R", "period", "hops", "impacts_per_s", "alpha_range", "regime", "line"]
samples_per_period = 16
lyapunov_window_s = 8.0

[[map.axes]]
key = "excitation.frequency_hz"
start = 5.0
end = 10.0
count = 3

[[map.axes]]
key = "excitation.amplitude_m"
start = 0.009
end = 0.023
count = 2
"""


def cli_binary() -> Path:
    """The `pendulum-atlas` binary of this checkout (`cargo build --release`), or the one
    PENDULUM_ATLAS_BIN names."""
    path = Path(os.environ.get("PENDULUM_ATLAS_BIN", REPO / "target" / "release" / "pendulum-atlas"))
    if not path.is_file():
        pytest.fail(f"no pendulum-atlas binary at {path}: run `cargo build --release` first, or set PENDULUM_ATLAS_BIN")
    return path


def run_cli(*args: str | os.PathLike) -> subprocess.CompletedProcess:
    """Run the command line; fail the test with its output when it fails."""
    done = subprocess.run([str(cli_binary()), *map(str, args)], capture_output=True, text=True)
    if done.returncode != 0:
        pytest.fail(f"pendulum-atlas {' '.join(map(str, args))} exited {done.returncode}:\n{done.stderr}")
    return done


def gpu_backends() -> list[str]:
    """The backends to compare on: the CPU always, the GPU where an adapter answers (and
    always under PENDULUM_ATLAS_REQUIRE_GPU=1, as `.ci/run` sets)."""
    if os.environ.get("PENDULUM_ATLAS_REQUIRE_GPU") == "1":
        return ["cpu", "gpu"]
    listed = subprocess.run([str(cli_binary()), "adapters"], capture_output=True, text=True)
    return ["cpu", "gpu"] if listed.returncode == 0 and "no GPU adapter" not in listed.stdout else ["cpu"]


@pytest.fixture
def small_map_file(tmp_path: Path) -> Path:
    path = tmp_path / "small.toml"
    path.write_text(SMALL_MAP, encoding="utf-8")
    return path
