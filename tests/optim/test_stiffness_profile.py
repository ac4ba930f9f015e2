"""The coarse K_cr(β) profile the stiffness design seeds from, and the known-B_max shortcut of the exact analysis.

``coarse_critical`` walks each curve segment over the sorted β's it crosses (work ∝ crossings);
``_coarse_critical_dense`` is the broadcast β's × segments form it replaced: two computations of the
same interpolation, which must agree exactly (same arithmetic per pair, min of the same set)."""

import numpy as np
import pytest

from models.device import Device
from optim.stability.margins import critical_stiffness, max_stable_damping
from optim.stiffness.profile import _coarse_critical_dense, boundary_curve, coarse_critical

LH = Device(preset="lhifam")
PH = Device(preset="phantom-1.0")
RED = Device(preset="lhifam-reduced-pretension")
DEVICES = {"lh-rigid": LH.rigid(), "lh-cable": LH, "ph-cable": PH, "red-cable": RED,
           "lh-rigid-d2.5": LH.rigid().model_copy(update={"delay": 2.5e-3}),
           "ph-cable-d0.37": PH.model_copy(update={"delay": 0.37 * PH.sample_time})}


@pytest.mark.parametrize("name", list(DEVICES))
def test_sparse_profile_equals_dense_profile(name):
    dev = DEVICES[name]
    beta_hi = max_stable_damping(dev) / dev.damping_scale
    curve = boundary_curve(dev, beta_hi)
    rng = np.random.default_rng(7)
    # unsorted, with repeats, with the curve's own vertices (a crossing exactly at a vertex is counted once)
    inside = curve.beta[(curve.beta > 0) & (curve.beta < beta_hi)]
    betas = np.concatenate([rng.uniform(0, beta_hi, 300), np.linspace(0, beta_hi, 50)[::-1], inside[:40],
                            [0.0, 0.0, beta_hi * (1 - 1e-9)]])
    sparse = coarse_critical(curve, betas)
    dense = _coarse_critical_dense(curve, betas)
    np.testing.assert_array_equal(sparse, dense)
    assert np.isfinite(sparse).any() and (sparse > 0).any()


@pytest.mark.parametrize("name", list(DEVICES))
@pytest.mark.parametrize("fraction", [0.0, 0.3, 0.999])
def test_known_b_max_gives_the_same_answer(name, fraction):
    dev = DEVICES[name]
    b_max = max_stable_damping(dev)
    b = fraction * b_max
    assert critical_stiffness(dev, b, b_max=b_max) == critical_stiffness(dev, b)
    # at and above B_max the shortcut still answers K_cr = 0 with the reason
    above = critical_stiffness(dev, 1.01 * b_max, b_max=b_max)
    assert above.critical_stiffness == 0.0 and "B_max" in above.reason
