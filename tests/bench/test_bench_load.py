"""The load benchmark at reduced size (16 clients for 8 s, a 5 s budget) against a real server, holding issue 18's
targets: /healthz p99 ≤ 200 ms and cheap analyses p99 ≤ 500 ms while heavy requests fill the compute queue;
every heavy request answers 200, or 503 within budget + 1 s; the server's RSS after within 100 MB of before."""

import pytest

from bench import bench_load

pytestmark = [pytest.mark.e2e, pytest.mark.slow]


def test_bench_load_reduced_meets_the_targets():
    res = bench_load.run(clients=16, seconds=8.0, budget=5.0, compute_workers=2)
    text = bench_load.render(res)
    verdicts = bench_load.verdicts(res)
    assert all(ok for ok, _ in verdicts.values()), "\n" + text
    assert res["health_after"] == 200 and len(res["health_ms"]) > 50
    kinds = res["per_kind"]
    assert {v["kind"] for v in kinds.values()} == {"cheap", "heavy"}      # the mix was really sent
    assert sum(v["status"].get(200, 0) for v in kinds.values() if v["kind"] == "heavy") > 0
    assert max(d for d, _ in res["queue"]) > 0                              # the workers were saturated
    assert "| /healthz p99 ≤ 200 ms | yes |" in text
