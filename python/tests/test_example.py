"""examples/optimise_aerofoil.py runs (a short run) and writes its picture; skipped without
pymoo or matplotlib."""

import importlib.util
from pathlib import Path

import pytest

pytest.importorskip("pymoo")
pytest.importorskip("matplotlib")

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "optimise_aerofoil.py"


def test_the_pymoo_example_optimises_and_plots(tmp_path):
    spec = importlib.util.spec_from_file_location("optimise_aerofoil", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    png = tmp_path / "optimised.png"
    start, best = module.main(
        ["--generations", "3", "--population", "8", "--backend", "cpu", "--png", str(png)]
    )
    assert png.stat().st_size > 1000
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert best >= start - 1e-12
