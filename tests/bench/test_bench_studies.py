"""The study benchmark runs and renders (a tiny local-only version, so the script cannot rot)."""

import pytest

from bench import bench_studies
from optim.studies.problems import VECTOR_CHUNK_FACTOR, ProblemUnavailable, get_problem

pytestmark = pytest.mark.slow


def test_bench_studies_tiny():
    rows = bench_studies.measure(points=2, repeats=1, workers=(1,), dask=False, chunk_size=4, analysis_points=40)
    vector_chunk = 4 * VECTOR_CHUNK_FACTOR      # the runner's chunk of 4 × the vectorised problems' factor
    for problem, points, chunk in (("stability", 40, vector_chunk), ("critical_stiffness", 40, vector_chunk)):
        mine = [r for r in rows if r.problem == problem]
        assert [r.executor for r in mine] == [bench_studies.BASELINES[problem][0], "local pool, 1 worker"]
        assert [r.chunk for r in mine] == [None, chunk]
        assert all(r.points == points and r.failed == 0 and r.rate > 0 for r in mine)
    try:
        get_problem("stiffness")
        assert [(r.points, r.chunk) for r in rows if r.problem == "stiffness"] == [(2, None), (2, 4)]
    except ProblemUnavailable:
        assert len(rows) == 4
    text = bench_studies.render(rows)
    assert text.startswith("# Study throughput") and "| stability | local pool, 1 worker | 40 |" in text
    assert "| critical_stiffness | local pool, 1 worker | 40 |" in text and "Stability sweeps" in text
