"""A small copy of the filter property run (bench/bench_filter_properties.py writes the full one into
docs/properties_filter.md): every exact K_cr of a random rendered wall confirmed by the closed loop with the
filter's states, none contradicted, every not_checkable with its reason."""

from __future__ import annotations

import pytest

from tests.optim.stability.filter_properties import KINDS, run_filter_property


@pytest.mark.slow
def test_random_rendered_walls_are_confirmed():
    r = run_filter_property(150, seed=3)
    assert not r["contradicted"], r["contradicted"][:3]
    assert all(reason for reason in r["not_checkable"])
    assert r["cases"] >= 140 and r["confirmed"] >= 0.95 * r["cases"]
    assert r["confirmed_positive"] >= 60
    assert all(r["kinds"][k] >= 25 for k in KINDS)
    assert r["negative_mass"] >= 20 and r["cable"] >= 40 and r["fractional"] >= 20
