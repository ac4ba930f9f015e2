"""The load benchmark runs against a real server process and renders (a 3-client, 2-second version)."""

from bench import bench_load


def test_bench_load_small():
    res = bench_load.run(clients=3, seconds=2.0, workers=1, baseline_repeats=1)
    text = bench_load.render(res)
    assert res["health_after"] == 200
    assert sum(v["errors"] for v in res["per_kind"].values()) == 0
    assert sum(len(v["ms"]) for v in res["per_kind"].values()) > 0
    assert res["rss_before_kib"] > 0 and "| stability rigid |" in text
