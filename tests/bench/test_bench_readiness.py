"""bench/bench_readiness.py's table: the verdict follows the worst first design (the live run itself is the
readiness test in tests/service/test_live_execution.py; the bench is run by hand on a quiet machine)."""

from bench.bench_readiness import GOAL_S, write


def _row(first: float) -> dict[str, float]:
    return {"cold_wall": 1.2, "cold_inside": 0.9, "to_ready": 6.5, "first": first, "warm": 0.02}


def test_the_verdict_is_the_worst_first_design(tmp_path):
    out = tmp_path / "r.md"
    write([_row(0.017), _row(0.020)], out, (0.1, 0.2))
    text = out.read_text()
    assert "median 18.5 ms, worst 20.0 ms over 2 fresh servers (met)" in text
    write([_row(0.017), _row(GOAL_S + 0.01)], out, (0.1, 0.2))
    assert "(**missed**)" in out.read_text()
