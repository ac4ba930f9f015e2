"""A tiny run of bench/bench_quantisation.py so the benchmark cannot rot (the full run writes
docs/quantisation_runs.md)."""

import pytest

from bench.bench_quantisation import main

pytestmark = pytest.mark.slow


def test_bench_quantisation_quick(tmp_path):
    out = tmp_path / "q.md"
    assert main(["--quick", "--workers", "1", "--out", str(out)]) == 0
    text = out.read_text()
    # the quick run's two Abbott points (8 walls) must all agree with the paper
    assert "8 of 8 walls agree with the paper" in text
    assert "## Limit cycles on random walls" in text and "## The (β, σ) plane" in text
