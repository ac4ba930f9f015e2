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


# issue 34: a box whose worst device is inside, not at a corner.  K_cr(B = 0.702) of this cable device falls from
# 2.30× its minimum at the soft end of the cable stiffness to the minimum at u ≈ 0.75 of the range and rises to
# 1.19× at the stiff end (found by a random search of cable boxes; 41-point scan).
INTERIOR_DEVICE = Device(sample_time=0.0024969915155867756, delay=0.001542752035595106,
                         cable={"motor_mass": 0.15247265754734599, "motor_damping": 0.0778703538763408,
                                "body_mass": 6.0917165915008, "body_damping": 1.5176300726956218,
                                "stiffness": 60476.333195172134, "damping": 0.5069352417881732})
INTERIOR_RANGES = {"device.cable.stiffness": (35860.06335438216, 85092.6030359621)}
INTERIOR_B = 0.7021722615641717


def _interior_minimum(box) -> float:
    """min over the box of K_cr(B): a 201-point scan refined by a bounded scalar search (scipy)."""
    from scipy.optimize import minimize_scalar

    from optim.stability.margins import critical_stiffness

    def kcr(u: float) -> float:
        return critical_stiffness(box.device_at(box.to_box([u])), INTERIOR_B).critical_stiffness

    us = [i / 200 for i in range(201)]
    i = min(range(201), key=lambda j: kcr(us[j]))
    res = minimize_scalar(kcr, bounds=(us[max(i - 1, 0)], us[min(i + 1, 200)]), method="bounded",
                          options={"xatol": 1e-10})
    return float(res.fun)


@pytest.mark.slow
def test_a_wall_violated_only_inside_the_box_is_contradicted_with_the_device():
    box = UncertaintyBox.from_ranges(INTERIOR_DEVICE, INTERIOR_RANGES)
    g = 10 ** (6.0 / 20)
    k_min = _interior_minimum(box)
    # 1e-4 too stiff for the interior minimum, > 1.4 dB inside the margin at both corners
    bad = vr.verify_robust_stiffness(box, k_min / g * (1 + 1e-4), INTERIOR_B, 6.0, False)
    assert bad.verdict == "contradicted", bad.reason
    corners = [p for p in bad.points if p.kind == "corner"]
    assert all(p.verdict == "confirmed" and p.gain_margin_db > 7.4 for p in corners)
    inner = [p for p in bad.points if p.kind == "interior"]
    assert len(inner) == 1 and inner[0].verdict == "contradicted"
    assert 0.70 < (inner[0].device["device.cable.stiffness"] - box.lower[0]) / (box.upper[0] - box.lower[0]) < 0.80
    assert 6.0 - 1e-3 < inner[0].gain_margin_db < 6.0 - 5e-4          # 20·log10(1 + 1e-4) = 8.7e-4 dB short
    # the same wall backed off by 1e-6 below the interior minimum is confirmed, the interior device included
    good = vr.verify_robust_stiffness(box, k_min / g * (1 - 1e-6), INTERIOR_B, 6.0, False)
    assert good.verdict == "confirmed", good.reason
    assert [p.kind for p in good.points] == ["corner", "corner", "interior"]


@pytest.mark.slow
def test_the_worst_case_search_finds_the_interior_minimum():
    from optim.robust.worst_case import worst_case_stiffness

    box = UncertaintyBox.from_ranges(INTERIOR_DEVICE, INTERIOR_RANGES)
    wc = worst_case_stiffness(box, 1.0, INTERIOR_B)
    assert wc.critical_stiffness == pytest.approx(_interior_minimum(box), rel=1e-8)


# issue 34, the inertia design: K_f,cr at an 80 Hz second-order cutoff of the LHIfAM cable over its cable stiffness
# 0.1-0.8 × 79,500 N/m falls from 1.94 at the soft end to its minimum ≈ 1.208 at u ≈ 0.29 and rises to 2.11 at the
# stiff end (29-point scan): the worst device is inside the box, and the corners alone are > 4 dB clear of it.
INERTIA_DEVICE = Device(preset="lhifam")
INERTIA_RANGES = {"device.cable.stiffness": (7950.0, 63600.0)}
INERTIA_CUTOFF = 80.0


def _interior_force_gain_minimum(box) -> float:
    """min over the box of K_f,cr at the cutoff: a 41-point scan refined by a bounded scalar search (scipy)."""
    from scipy.optimize import minimize_scalar

    from models.filters import ButterworthLowPass
    from optim.transparency.feedforward import critical_force_gain, resolve_human

    def kcr(u: float) -> float:
        d = box.device_at(box.to_box([u]))
        f = ButterworthLowPass(order=2, cutoff_hz=INERTIA_CUTOFF, sample_time=d.sample_time)
        return float(critical_force_gain(d, f, resolve_human(d)[0]).critical_force_gain)

    us = [i / 40 for i in range(41)]
    i = min(range(41), key=lambda j: kcr(us[j]))
    res = minimize_scalar(kcr, bounds=(us[max(i - 1, 0)], us[min(i + 1, 40)]), method="bounded",
                          options={"xatol": 1e-10})
    return float(res.fun)


@pytest.mark.slow
def test_an_inertia_design_violated_only_inside_the_box_is_contradicted_with_the_device():
    box = UncertaintyBox.from_ranges(INERTIA_DEVICE, INERTIA_RANGES)
    g = 10 ** (6.0 / 20)
    k_min = _interior_force_gain_minimum(box)
    bad = vr.verify_robust_inertia(box, k_min / g * (1 + 1e-4), INERTIA_CUTOFF, 2, 6.0)
    assert bad.verdict == "contradicted", bad.reason
    corners = [p for p in bad.points if p.kind == "corner"]
    assert all(p.verdict == "confirmed" and p.gain_margin_db > 10.0 for p in corners)
    inner = [p for p in bad.points if p.kind == "interior"]
    assert len(inner) == 1 and inner[0].verdict == "contradicted"
    u = (inner[0].device["device.cable.stiffness"] - box.lower[0]) / (box.upper[0] - box.lower[0])
    assert 0.2 < u < 0.4
    assert 6.0 - 1e-3 < inner[0].gain_margin_db < 6.0 - 5e-4          # 20·log10(1 + 1e-4) = 8.7e-4 dB short
    assert "interior search" in bad.reason
    good = vr.verify_robust_inertia(box, k_min / g * (1 - 1e-6), INERTIA_CUTOFF, 2, 6.0)
    assert good.verdict == "confirmed", good.reason
    assert [p.kind for p in good.points] == ["corner", "corner", "interior"]
