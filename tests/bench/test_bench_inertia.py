"""A tiny run of bench/bench_inertia.py so the benchmark cannot rot (timings are not asserted)."""

from __future__ import annotations

import pytest

from bench.bench_inertia import run

pytestmark = pytest.mark.slow


def test_tiny_benchmark_run(tmp_path):
    out = tmp_path / "bench_inertia.md"
    rows = run(repeats=1, comparator_repeats=1, out=out, dense_points=12)
    text = out.read_text()
    assert "| case |" in text and len(rows) >= 4
    for r in rows:
        assert r["status"] == "optimal" and r["margin"] >= 6 - 1e-6
        if "target" in r["case"]:
            assert r["cutoff"] >= r["fc_dense"]                       # exact boundary ≥ last feasible grid point
        else:
            assert r["force_gain"] >= r["kf_dense"] * (1 - 1e-12)     # never worse than the scan
