"""A tiny run of bench/bench_stiffness.py so the benchmark cannot rot."""

import importlib.util
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow


def test_bench_stiffness_quick(tmp_path):
    path = Path(__file__).resolve().parents[2] / "bench" / "bench_stiffness.py"
    spec = importlib.util.spec_from_file_location("bench_stiffness", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    out = tmp_path / "bench.md"
    rows = mod.main(["--quick", "--repeats", "2", "--out", str(out)])
    assert out.read_text().startswith("# Stiffness design benchmark")
    assert all(r["status"] == "optimal" for r in rows)
    assert all(abs(r["rel_diff"]) < 1e-4 for r in rows)
