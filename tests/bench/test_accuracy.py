"""The accuracy benchmark's 5-case version (plus two feedforward cases) runs, renders and keeps its promises."""

import math

import pytest

from bench import accuracy_vs_time as acc


@pytest.fixture(scope="module")
def quick():
    return acc.measure(acc.QUICK, repeats=1)


@pytest.mark.slow
def test_accuracy_quick_suite(tmp_path, quick):
    results, details = quick
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


@pytest.mark.slow
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


@pytest.mark.slow
def test_accuracy_verify_column_and_readme_headline(tmp_path, quick):
    results, details = quick
    # verify confirms every exact and reference answer of the suite, and its cost has its own column
    for rung in ("exact", "reference"):
        assert results[rung].verdicts and set(results[rung].verdicts) == {"confirmed"}
    text = acc.render(results, details)
    assert "verify median ms" in text
    table = acc.headline(results)
    readme = tmp_path / "README.md"
    readme.write_text(f"intro\n{acc.README_START}\nold\n{acc.README_END}\nafter\n")
    acc.write_readme_headline(readme, table)
    assert readme.read_text() == f"intro\n{acc.README_START}\n{table}\n{acc.README_END}\nafter\n"


def test_readme_headline_matches_docs_accuracy():
    """The README's headline rows are the generated table's own numbers (median ms, max error, wrong count)."""
    from pathlib import Path

    root = Path(acc.__file__).resolve().parents[1]
    readme = (root / "README.md").read_text()
    block = readme.split(acc.README_START, 1)[1].split(acc.README_END, 1)[0]
    docs = (root / "docs" / "accuracy.md").read_text().split("## Force feedforward")[0]
    rows = {r.split("|")[1].strip(): [c.strip() for c in r.split("|")[1:-1]] for r in docs.splitlines()
            if r.startswith("| ") and "median ms" not in r}
    names = {"linear (eq. 10)": "linear", "python-control `stability_margins`": "python-control default"}
    for line in block.strip().splitlines()[2:]:
        cells = [c.strip() for c in line.split("|")[1:-1]]
        key = names.get(cells[0], cells[0])
        assert key in rows, key
        doc = rows[key]
        assert float(cells[1]) == float(f"{float(doc[1]):.2g}"), (key, cells[1], doc[1])
        assert cells[3] == doc[5], (key, cells[3], doc[5])
        if key != "reference":
            assert cells[2] == doc[4], (key, cells[2], doc[4])
