"""A tiny run of bench/bench_simulate_verdicts.py so the benchmark cannot rot."""

import pytest

from bench.bench_simulate_verdicts import main

pytestmark = pytest.mark.slow


def test_bench_simulate_verdicts_quick(tmp_path):
    out = tmp_path / "v.md"
    assert main(["--quick", "--out", str(out)]) == 0
    text = out.read_text()
    assert "| all | 41 |" in text and "contradictions" in text
