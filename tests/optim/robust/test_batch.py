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
