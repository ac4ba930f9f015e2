"""A tiny run of bench/bench_simulate.py so the benchmark cannot rot."""

import importlib.util
from pathlib import Path

import pytest


@pytest.mark.slow     # a benchmark's smoke run (≈ 1 s): CI runs it, the fast loop does not
def test_bench_simulate_quick(tmp_path):
    path = Path(__file__).resolve().parents[2] / "bench" / "bench_simulate.py"
    spec = importlib.util.spec_from_file_location("bench_simulate", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    out = tmp_path / "b.md"
    assert mod.main(["--quick", "--out", str(out)]) == 0
    text = out.read_text()
    assert "exact-linear-recursion" in text and "event-integrator" in text and "solve_ivp" in text
