"""A tiny run of bench/bench_service.py so the benchmark cannot rot (speed is judged by the benchmark itself)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.e2e

ROOT = Path(__file__).resolve().parents[2]


def test_tiny_service_benchmark_runs_and_writes_its_table(tmp_path):
    spec = importlib.util.spec_from_file_location("bench_service", ROOT / "bench" / "bench_service.py")
    bench = importlib.util.module_from_spec(spec)
    sys.modules["bench_service"] = bench  # dataclasses look their module up by name
    try:
        spec.loader.exec_module(bench)
    except BaseException:
        del sys.modules["bench_service"]
        raise
    out = tmp_path / "bench_service.md"
    result = bench.run(duration=0.5, clients=2, n_seq=20, out=out)
    text = out.read_text(encoding="utf-8")
    assert "| uvicorn, 1 client (sequential) |" in text and "comparator: analyse_stability" in text
    assert result["load"].throughput > 0 and result["load"].n > 0
    for s in result.values():
        assert 0 < s.p50_ms <= s.p95_ms
