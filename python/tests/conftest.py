"""Shared fixtures: the CLI binary and one synthetic scene written by it."""

import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def cli() -> Path:
    """The `mapgauge` binary the Python results are compared with: $MAPGAUGE_BIN,
    else the workspace's release build. Missing is a failure, not a skip: the
    "same numbers" tests are the point of this suite."""
    p = Path(os.environ.get("MAPGAUGE_BIN", REPO / "target" / "release" / "mapgauge"))
    if not p.is_file():
        pytest.fail(f"{p} not found: run `cargo build --release` first or set MAPGAUGE_BIN")
    return p


def run_cli(cli: Path, *args: str, check: bool = True) -> subprocess.CompletedProcess:
    r = subprocess.run([str(cli), *args], capture_output=True, text=True)
    if check and r.returncode != 0:
        raise AssertionError(f"mapgauge {' '.join(args)} failed: {r.stderr}")
    return r


@pytest.fixture(scope="session")
def scene(cli: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 1 M-point scene (PLY with double coordinates, 5 targets, one of which
    the pipeline cannot locate) written by `mapgauge synth`."""
    d = tmp_path_factory.mktemp("scene")
    run_cli(cli, "synth", "--out", str(d), "--points", "1000000", "--seed", "2")
    return d
