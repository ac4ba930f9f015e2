"""A tiny run of bench/bench_robust.py so the benchmark cannot rot."""

import importlib.util
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow


def test_bench_robust_quick(tmp_path):
    path = Path(__file__).resolve().parents[2] / "bench" / "bench_robust.py"
    spec = importlib.util.spec_from_file_location("bench_robust", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    out = tmp_path / "bench.md"
    rows = mod.main(["--quick", "--repeats", "1", "--out", str(out)])
    assert out.read_text().startswith("# Robust stiffness design benchmark")
    assert all(r["status"] == "optimal" and r["margin"] >= 6 - 1e-6 for r in rows)
    assert all(r["scenarios"] >= 1 + 2 ** r["n"] for r in rows)
