"""A tiny run of bench/bench_service.py so the benchmark cannot rot (speed is judged by the benchmark itself)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

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
    result = bench.run(duration=1.0, clients=4, workers=(1,), loop_repeats=3, n_numerics=20, out=out)
    text = out.read_text(encoding="utf-8")
    assert "| 1 | rigid exact analysis, 1 client |" in text and "| 1 | /healthz, 4 clients |" in text
    assert "numerics alone" in text and "python-control" in text
    for row in result["loads"][1]:
        assert row.requests > 0 and row.errors == 0 and row.rps > 0 and 0 < row.p50_ms <= row.p95_ms
    assert len(result["loops"]) == len(bench.LOOPS)
    for loop in result["loops"]:
        assert 0 < loop.http_elapsed_ms < loop.http_wall_ms and loop.control_ms > 0


def test_fallback_load_generator_counts_requests_and_errors(tmp_path):
    """bench/loadgen.py (used when wrk is absent): a 404 path counts every answer as an error."""
    import json
    import subprocess

    from bench.live_server import LiveServer

    server = LiveServer(env={"ZWIDTH_COMPUTE_WORKERS": "1", "ZWIDTH_PRESTART_WORKERS": "false"})
    try:
        for path, bad in (("/healthz", False), ("/no-such-route", True)):
            out = subprocess.run([sys.executable, "-m", "bench.loadgen", "--port", str(server.port), "--path", path,
                                  "--connections", "2", "--duration", "0.5"], capture_output=True, text=True,
                                 check=True, cwd=ROOT, timeout=60).stdout
            r = json.loads(out)
            assert r["requests"] > 0 and r["rps"] > 0
            assert r["errors"] == (r["requests"] if bad else 0)
    finally:
        server.stop()
