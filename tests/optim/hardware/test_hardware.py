"""Inverse (hardware) design: every answer checked by forward designs at the value and 1 % beyond it."""

import math

import numpy as np
import pytest

from models.device import Device
from optim.hardware.design import HardwareTarget, design_hardware, device_with
from optim.stability.margins import critical_stiffness
from optim.stiffness import StiffnessRequirements, design_stiffness

LH = Device(preset="lhifam")
RIGID = LH.rigid()

CASES = [
    ("rigid-T", RIGID, "sample_time", HardwareTarget(2e5)),
    ("rigid-delay", RIGID, "delay", HardwareTarget(2e5)),
    ("rigid-delay-capped", RIGID, "delay", HardwareTarget(2e4, max_damping=50.0)),
    ("rigid-damping-capped", RIGID.model_copy(update={"delay": 0.001}), "damping", HardwareTarget(1e4, max_damping=20.0)),
    ("rigid-mass-free-B", RIGID, "mass", HardwareTarget(2e6)),
    ("cable-T", LH, "sample_time", HardwareTarget(5e4)),
]


def _forward(dev, free, value, target):
    return design_stiffness(device_with(dev, free, value), StiffnessRequirements(
        min_gain_margin_db=target.min_gain_margin_db, max_damping=target.max_damping))


@pytest.mark.slow
@pytest.mark.parametrize("name,dev,free,target", CASES, ids=[c[0] for c in CASES])
def test_answer_checked_by_forward_designs(name, dev, free, target):
    r = design_hardware(dev, target, free, points=21)
    assert r.status == "optimal" and r.bounded, r.note
    # at the value: the best wall is the target, i.e. the target's margin with that B is the requirement
    at = _forward(dev, free, r.value, target)
    assert at.status == "optimal"
    kcr = critical_stiffness(device_with(dev, free, r.value), at.damping).critical_stiffness
    assert 20 * math.log10(kcr / target.stiffness) == pytest.approx(target.min_gain_margin_db, abs=1e-6)
    assert r.controller["gain_margin_db"] == pytest.approx(target.min_gain_margin_db, abs=1e-6)
    # 1 % looser: the target is no longer reachable
    beyond = r.value * (1.01 if r.direction == "max" else 0.99)
    if r.value == 0.0:
        pytest.fail("a zero loosest value cannot be loosened by 1 %")
    assert _forward(dev, free, beyond, target).stiffness < target.stiffness


def test_rigid_mass_with_free_damping_matters_and_with_capped_damping_saturates():
    """Table 1: K* = (m/T²)·α*(bT/m, d).  With B free, K* grows with m (a target sets the lightest device);
    with B ≤ B_cap, K* tends to g·(b + B_cap)/(T/2 + t_d) (eq. 10) as m grows: mass stops mattering."""
    free_b = design_hardware(RIGID, HardwareTarget(2e6), "mass", points=15)
    k = np.array([p["achievable_stiffness"] for p in free_b.curve])
    assert free_b.matters and np.all(np.diff(k) > 0) and k[-1] / k[0] > 100
    capped = design_hardware(RIGID, HardwareTarget(1e4, max_damping=50.0), "mass", points=15)
    kc = np.array([p["achievable_stiffness"] for p in capped.curve])
    eq10 = 10 ** (-6 / 20) * (RIGID.damping + 50.0) / (RIGID.sample_time / 2)
    assert kc[-1] == pytest.approx(eq10, rel=2e-3)        # heaviest: β → 0, the linear regime
    assert (kc[-1] - kc[-3]) / kc[-1] < 1e-3               # flat at the heavy end


@pytest.mark.slow
def test_feasible_set_of_two_intervals():
    """LHifAM cable, B ≤ 20 N·s/m: K*(k_c) falls to a minimum near k_c ≈ 1e6 N/m and rises again."""
    r = design_hardware(LH, HardwareTarget(1.85e4, max_damping=20.0), "cable.stiffness", points=41)
    assert r.status == "optimal" and len(r.intervals) == 2
    assert "not one interval" in r.note
    (a0, a1), (b0, b1) = r.intervals
    assert a1 < b0
    for edge in (a1, b0):
        k = _forward(LH, "cable.stiffness", edge, HardwareTarget(1.85e4, max_damping=20.0)).stiffness
        assert k == pytest.approx(1.85e4, rel=1e-9)
    mid = math.sqrt(a1 * b0)
    assert _forward(LH, "cable.stiffness", mid, HardwareTarget(1.85e4, max_damping=20.0)).stiffness < 1.85e4


def test_infeasible_target_names_best_and_limit():
    # a requested range is scanned as given: 1e12 N/m needs far faster sampling than 33 µs
    r = design_hardware(RIGID, HardwareTarget(1e12), "sample_time", points=11, value_range=(1e-3 / 30, 0.03))
    assert r.status == "infeasible" and r.value is None and r.range_source == "request"
    assert r.best_achievable_stiffness < 1e12 and "best achievable" in r.reason
    # measured: halving the sample time beyond the range helps most
    assert "sampling" in r.limiting_effect and "sample_time /2" in r.limiting_effect
    # the best value is the fastest sampling of the scan (K* falls with T)
    assert r.best_value == pytest.approx(min(p["value"] for p in r.curve))


def test_bad_free_parameter():
    with pytest.raises(ValueError, match="free"):
        design_hardware(RIGID, HardwareTarget(1e4), "cable.stiffness")
