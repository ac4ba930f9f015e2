"""A tiny run of bench/bench_design_http.py so the benchmark cannot rot (the speed is judged by its table)."""

from __future__ import annotations

import pytest

pytestmark = [pytest.mark.e2e, pytest.mark.slow]


def test_tiny_design_benchmark_runs_and_writes_its_table(tmp_path):
    from bench import bench_design_http as bench

    out = tmp_path / "bench_design_http.md"
    result = bench.run(n=5, out=out)
    text = out.read_text(encoding="utf-8")
    assert "| design in a worker process" in text and "| comparator: design inline" in text
    assert set(result) == {"worker", "inline"}
    for s in result.values():
        assert s.n == 5 and 0 < s.p50_ms <= s.p95_ms
