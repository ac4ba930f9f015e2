"""The study benchmark runs and renders (a tiny local-only version, so the script cannot rot)."""

from bench import bench_studies


def test_bench_studies_tiny():
    rows = bench_studies.measure(points=8, repeats=1, workers=(1,), dask=False, chunk_size=4)
    assert [r.executor for r in rows][:2] == ["single point, in-process (baseline)", "local pool, 1 worker"]
    assert all(r.points == 8 and r.failed == 0 and r.rate > 0 for r in rows)
    text = bench_studies.render(rows)
    assert text.startswith("# Study throughput") and "| stability | local pool, 1 worker | 8 |" in text
