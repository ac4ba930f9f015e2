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


def test_bench_core_counts_cable_fallbacks():
    """The cable rows take the brackets (path "fast"), and the fallback count is rendered."""
    rows = bench_core.measure(cases=[c for c in bench_core.CASES if c[0] == "cable LHifAM, d=5"], repeats=2)
    assert rows[0].path == "fast" and abs(rows[0].exact / rows[0].truth - 1) < 1e-12
    cables = bench_core.measure_cable_fallbacks(12)
    assert cables.fast + cables.bounded + cables.other == 12 and cables.fast >= 10
    text = bench_core.render(rows, cables=cables, load=(1.0, 2.0))
    assert "## Cable fallbacks" in text and "load average 1.0" in text
