"""The core benchmark runs and renders (a two-case version, so the script cannot rot)."""

import pytest

from bench import bench_core

pytestmark = pytest.mark.slow


def test_bench_core_small(tmp_path):
    rows = bench_core.measure(cases=[bench_core.CASES[0], bench_core.CASES[8]], repeats=2)
    text = bench_core.render(rows)
    assert "| rigid LHifAM, d=0 |" in text and "python-control" in text
    # the tiny-damping long-delay case: zwidth right, python-control's default answer wrong (FIELD-NOTES)
    tiny = rows[1]
    assert abs(tiny.exact / tiny.truth - 1) < 1e-9
    assert abs(tiny.ctrl / tiny.truth - 1) > 0.01
    out = tmp_path / "b.md"
    out.write_text(text)
    assert out.read_text().startswith("# Critical stiffness")
