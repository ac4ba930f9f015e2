"""The batched exact analysis against optim.stability.margins.critical_stiffness, device by device."""

import math

import numpy as np
import pytest

from models.device import Device
from optim.robust.batch import batch_critical_stiffness
from optim.stability.margins import critical_stiffness
from tests.optim.test_stiffness_design import _random_devices


def _compare(devices, dampings):
    res = batch_critical_stiffness(devices, dampings)
    for i, (dev, b) in enumerate(zip(devices, dampings)):
        ref = critical_stiffness(dev, float(b))
        got = res.critical_stiffness[i]
        # both refine every crossover to a 4-ulp bracket: agreement to 1e-9 leaves room for the different grids
        if ref.critical_stiffness == 0.0 or math.isinf(ref.critical_stiffness):
            assert got == ref.critical_stiffness, (i, dev, b)
        else:
            assert got == pytest.approx(ref.critical_stiffness, rel=1e-9), (i, dev, b)
            assert res.crossover_angle[i] / dev.sample_time == pytest.approx(ref.crossover_frequency, rel=1e-7)
        if b > 0:
            assert res.max_stable_damping[i] == pytest.approx(ref.max_stable_damping, rel=1e-9)
    return res


@pytest.mark.parametrize("seed", [3, 11])
def test_random_devices_any_damping(seed):
    """Rigid and cable devices, whole and fractional delays, B from 0 to past B_max (K_cr = 0 there)."""
    devices = _random_devices(90, seed=seed)
    rng = np.random.default_rng(seed)
    b = np.array([0.0 if i % 5 == 0 else rng.uniform(0, 0.9) * d.damping_scale for i, d in enumerate(devices)])
    res = _compare(devices, b)
    assert (res.critical_stiffness == 0).sum() >= 5          # the B ≥ B_max branch is exercised
    assert (res.critical_stiffness > 0).sum() >= 40


def test_cable_stiffness_switch_is_seen():
    """LHifAM at B = 0: the critical crossover jumps from the resonance (θ ≈ 0.5) to a low one as k_c grows."""
    base = Device(preset="lhifam")
    devs = [base.model_copy(update={"cable": base.cable.model_copy(update={"stiffness": k})})
            for k in np.geomspace(2e4, 2e5, 25)]
    res = _compare(devs, np.zeros(len(devs)))
    assert res.crossover_angle.max() > 0.3 and res.crossover_angle.min() < 0.06


def test_damped_cables_take_the_single_device_answer_bit_for_bit():
    """Damped cables are not scanned in the batch: each row is optim.stability.margins' own answer (the cable
    brackets, else its bounded scan), B_max included, the same in any chunk; an undamped cable is still scanned."""
    from optim.stability.margins import max_stable_damping

    cables = [d for d in _random_devices(60, seed=8) if d.cable is not None]
    undamped = Device(cable=dict(motor_mass=0.3, body_mass=5.1, motor_damping=0.0, body_damping=0.0,
                                 stiffness=79500.0, damping=0.0), sample_time=1e-3, delay=2e-3)
    devices = cables + [undamped]
    rng = np.random.default_rng(8)
    b = np.array([0.0 if i % 3 == 0 else rng.uniform(0, 1.2) * max_stable_damping(d)
                  for i, d in enumerate(cables)] + [0.0])
    with np.errstate(all="ignore"):      # as the studies call it: the undamped cable's scan divides by 0 at its pole
        res = batch_critical_stiffness(devices, b)
    assert res.scanned == 1
    for i, (dev, bi) in enumerate(zip(cables, b)):
        bm = max_stable_damping(dev)
        ref = critical_stiffness(dev, float(bi), b_max=bm if bi > 0 else None)
        assert res.critical_stiffness[i] == ref.critical_stiffness and res.max_stable_damping[i] == bm, (dev, bi)
        if ref.crossover_frequency is not None:
            assert res.crossover_angle[i] == ref.crossover_frequency * dev.sample_time
    for i in (0, 5, len(cables) - 1):
        one = batch_critical_stiffness([devices[i]], b[i:i + 1])
        assert one.critical_stiffness[0] == res.critical_stiffness[i]
        assert one.max_stable_damping[0] == res.max_stable_damping[i]
