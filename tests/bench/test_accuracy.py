"""The accuracy benchmark's 5-case version (plus two feedforward cases) runs, renders and keeps its promises."""

import math

from bench import accuracy_vs_time as acc


def test_accuracy_quick_suite(tmp_path):
    results, details = acc.measure(acc.QUICK, repeats=1)
    assert len(details) == 5
    # exact within 1e-9 of the 40-digit reference on every case
    assert max(results["exact"].errors) <= 1e-9
    # the linear rung's estimate is honest: the true error never exceeds it by more than 2x
    lin = results["linear"]
    assert all(e <= 2 * est for e, est in zip(lin.errors, lin.estimates) if math.isfinite(e))
    # the grid rung becomes wrong where FIELD-NOTES says it must (tiny damping, long delay)
    assert "rigid δ=1e-09 d=200" in [c for c, e in zip(results["grid"].cases, results["grid"].errors) if e > 0.01]
    text = acc.render(results, details)
    assert "| exact |" in text and "first wrong case" in text
    acc.plot(results, tmp_path / "a.png")
    assert (tmp_path / "a.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_accuracy_quick_feedforward():
    results, details = acc.measure_feedforward(acc.QUICK_FF, repeats=1)
    assert len(details) == 2
    # exact K_f,cr within 1e-9 of the independent 40-digit residue reference
    assert max(results["exact"].errors) <= 1e-9
    lin = results["linear"]
    # eq. 33 is far off at no delay (37.1 vs 3.7): the estimate must say so, and stay honest
    assert max(lin.errors) > 0.5
    assert all(e <= 2 * est for e, est in zip(lin.errors, lin.estimates))
    text = acc.render_feedforward(results, details)
    assert "## Force feedforward" in text and "| reference |" in text
