"""verify on robust designs (optim.verification_robust): every corner of the box and the worst device found, each
on the closed loop, one verdict per point and the worst of them overall; a design that misses its margin at a
corner, or is unstable there, is contradicted."""

from __future__ import annotations

import pytest

import optim.verification_robust as vr
from models.device import Device
from optim.robust.box import UncertaintyBox
from optim.robust.inertia import robust_design_inertia
from optim.robust.stiffness import robust_design_stiffness
from optim.stiffness import StiffnessRequirements
from optim.transparency.inertia import InertiaRequirements
from optim.verification import Verification

RIGID = Device(preset="lhifam").rigid()
RANGES = {"device.mass": (4.0, 7.0), "device.delay": (0.0, 0.002)}


@pytest.fixture(scope="module")
def passive_design():
    box = UncertaintyBox.from_ranges(RIGID, RANGES)
    d = robust_design_stiffness(RIGID, StiffnessRequirements(min_gain_margin_db=6.0, passivity=True), box)
    assert d.status == "optimal" and "passivity" in d.active_constraints
    return box, d


def _verify(box, d, stiffness=None):
    return vr.verify_robust_stiffness(box, d.stiffness if stiffness is None else stiffness, d.damping, 6.0, True,
                                      d.worst_case["device"], d.passivity_worst_case["device"])


def test_robust_stiffness_design_confirmed_at_every_corner(passive_design):
    box, d = passive_design
    v = _verify(box, d)
    assert v.verdict == "confirmed", v.reason
    corners = [p for p in v.points if p.kind == "corner"]
    assert sorted(tuple(p.device.values()) for p in corners) == [(4.0, 0.0), (4.0, 0.002), (7.0, 0.0), (7.0, 0.002)]
    assert all(p.verdict == "confirmed" and p.gain_margin_db >= 6.0 for p in v.points)
    # the least passive device (nominal mass, longest delay) is not a corner: it is checked too
    assert [p.kind for p in v.points if p.kind != "corner"] == ["least passive"]
    # the binding corner sits on the margin by the design's back-off
    assert min(p.gain_margin_db for p in corners) == pytest.approx(6.0, abs=1e-6)
    assert v.reason.startswith("5 devices of the box")


def test_a_wall_missing_its_margin_or_unstable_at_a_corner_is_contradicted(passive_design):
    box, d = passive_design
    v = _verify(box, d, stiffness=d.stiffness * 1.05)
    assert v.verdict == "contradicted"
    bad = [p for p in v.points if p.verdict == "contradicted"]
    assert bad and all("below the required 6 dB" in p.reason for p in bad)
    # 3× above K_cr at the worst corner: the wall itself is unstable there (and not passive)
    v = _verify(box, d, stiffness=d.stiffness * 2 * 3)
    worst = min(v.points, key=lambda p: p.gain_margin_db)
    assert v.verdict == "contradicted" and worst.gain_margin_db < 0
    assert "the wall itself is unstable" in worst.reason


def test_a_point_that_cannot_be_checked_makes_the_whole_not_checkable(passive_design, monkeypatch):
    box, d = passive_design
    real = vr.verify_stiffness_design
    calls = []

    def one_undecided(device, *a, **kw):
        calls.append(device)
        v = real(device, *a, **kw)
        if len(calls) == 2:
            return Verification("not_checkable", v.method, None, None, None, None, None, None, None, 0.0,
                                "a pole within rounding of the unit circle")
        return v

    monkeypatch.setattr(vr, "verify_stiffness_design", one_undecided)
    v = _verify(box, d)
    assert v.verdict == "not_checkable"
    assert "1 not checkable" in v.reason and "a pole within rounding of the unit circle" in v.reason
    assert [p.verdict for p in v.points].count("not_checkable") == 1


@pytest.mark.slow
def test_robust_inertia_design_confirmed_and_a_larger_gain_contradicted():
    box = UncertaintyBox.from_ranges(RIGID, {"device.mass": (5.0, 6.0)})
    d = robust_design_inertia(RIGID, InertiaRequirements(), box)
    assert d.status == "optimal"
    v = vr.verify_robust_inertia(box, d.force_gain, d.filter_cutoff_hz, d.filter_order, 6.0, d.worst_case["device"])
    assert v.verdict == "confirmed", v.reason
    assert {p.device["device.mass"] for p in v.points} == {5.0, 6.0}
    assert min(p.gain_margin_db for p in v.points) == pytest.approx(6.0, abs=1e-9)
    v = vr.verify_robust_inertia(box, d.force_gain * 1.1, d.filter_cutoff_hz, d.filter_order, 6.0,
                                 d.worst_case["device"])
    assert v.verdict == "contradicted" and "below the required 6 dB" in v.reason
