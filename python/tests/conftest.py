"""Shared fixtures: the repository's data and the `bezchain` binary the numbers are compared with."""

import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "data"


def _binary():
    """The CLI: $BEZCHAIN_BIN, else the repository's release or debug build, else PATH."""
    env = os.environ.get("BEZCHAIN_BIN")
    if env:
        return env
    for profile in ("release", "debug"):
        for target in (os.environ.get("CARGO_TARGET_DIR"), ROOT / "target"):
            if target and (Path(target) / profile / "bezchain").is_file():
                return str(Path(target) / profile / "bezchain")
    return shutil.which("bezchain")


@pytest.fixture(scope="session")
def cli():
    """Run `bezchain ARGS...` and return its completed process (skips without a binary)."""
    exe = _binary()
    if exe is None:
        pytest.skip("no bezchain binary (set BEZCHAIN_BIN or build the CLI with cargo build)")

    def run(*args, check=True):
        p = subprocess.run([exe, *map(str, args)], capture_output=True, text=True)
        if check and p.returncode != 0:
            raise AssertionError(f"bezchain {' '.join(map(str, args))} failed: {p.stderr}")
        return p

    return run


@pytest.fixture(scope="session")
def naca4413():
    return DATA / "naca4413.dat"


@pytest.fixture(scope="session")
def blade_json():
    return DATA / "blade_paper.json"
