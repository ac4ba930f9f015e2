"""The study benchmark runs and renders (a tiny local-only version, so the script cannot rot)."""

from bench import bench_studies
from optim.studies import ProblemUnavailable, get_problem


def test_bench_studies_tiny():
    rows = bench_studies.measure(points=8, repeats=1, workers=(1,), dask=False, chunk_size=4,
                                 critical_points=40, critical_chunk=16, stiffness_points=2)
    for problem, points, chunk in (("stability", 8, 4), ("critical_stiffness", 40, 16)):
        mine = [r for r in rows if r.problem == problem]
        assert [r.executor for r in mine] == ["single point, in-process (baseline)", "local pool, 1 worker"]
        assert [r.chunk for r in mine] == [None, chunk]
        assert all(r.points == points and r.failed == 0 and r.rate > 0 for r in mine)
    try:
        get_problem("stiffness")
        assert [r.points for r in rows if r.problem == "stiffness"] == [2, 2]  # stiffness_points
    except ProblemUnavailable:
        assert len(rows) == 4
    text = bench_studies.render(rows)
    assert text.startswith("# Study throughput") and "| stability | local pool, 1 worker | 8 |" in text
    assert "| critical_stiffness | local pool, 1 worker | 40 |" in text and "K_cr of a sweep" in text
