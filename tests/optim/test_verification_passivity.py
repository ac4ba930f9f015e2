"""verify's independent passivity requirement against 40-digit mpmath, and designs on their passivity constraint.

optim.verification._required_damping evaluates the delayed Colgate–Schenkel condition from its complex form; its
tolerance PASSIVITY_RTOL (1e-12 of the rounding scale) must cover its rounding error with a wide margin, and the
design back-off DESIGN_BACK_OFF (1e-8 of K) must put every design on its passivity constraint outside that band.
"""

from __future__ import annotations

import math
import warnings

import mpmath as mp
import numpy as np
import pytest

from models.device import Device
from optim.stiffness import StiffnessRequirements, design_stiffness
from optim.stiffness.requirements import DESIGN_BACK_OFF
from optim.verification import PASSIVITY_RTOL, _required_damping, _required_terms, verify_stiffness_design

#: measured bound on the recomputation's rounding error, in units of its rounding scale (16·u ≈ 1.8e-15 predicted)
ROUNDING_BOUND = 2e-15


def _mp_value(device: Device, k: float, b: float, whole: int, theta: float) -> mp.mpf:
    """The same expression in 40 digits (Dirichlet form (KT/2)·s_d(θ) − B·cos((d+1)θ); the limit at θ = 0)."""
    with mp.workdps(40):
        t = mp.mpf(device.sample_time)
        if theta == 0.0:
            return mp.mpf(k) * t * (whole + mp.mpf(1) / 2) - b
        x = mp.mpf(theta)
        s = mp.sin((whole + mp.mpf(1) / 2) * x) / mp.sin(x / 2)
        return mp.mpf(k) * t / 2 * s - mp.mpf(b) * mp.cos((whole + 1) * x)


def _random(rng: np.random.Generator) -> tuple[Device, float, float, int]:
    t = 10 ** rng.uniform(-4.5, -2)
    whole = int(rng.choice([0, rng.integers(1, 20), rng.integers(20, 2000), 10_000]))
    dev = Device(mass=1.0, damping=1.0, sample_time=t, delay=whole * t)
    k = 10 ** rng.uniform(0, 7)
    b = 0.0 if rng.random() < 0.2 else 10 ** rng.uniform(-3, 1) * k * t
    return dev, k, b, whole


def test_rounding_of_the_recomputed_requirement_is_within_its_bound():
    rng = np.random.default_rng(17)
    worst = 0.0
    for _ in range(40):
        dev, k, b, whole = _random(rng)
        for theta in np.concatenate([np.geomspace(1e-7, 1e-2, 5), rng.uniform(1e-2, math.pi, 5)]):
            got, scale = _required_terms(dev, k, b, whole, np.array([theta]))
            err = abs(float(got[0]) - float(_mp_value(dev, k, b, whole, float(theta)))) / float(scale[0])
            worst = max(worst, err)
    assert worst <= ROUNDING_BOUND, worst
    assert PASSIVITY_RTOL >= 100 * ROUNDING_BOUND and DESIGN_BACK_OFF >= 1000 * PASSIVITY_RTOL


def test_the_sup_is_found_and_the_limit_at_zero_is_exact():
    rng = np.random.default_rng(5)
    for _ in range(12):
        dev, k, b, whole = _random(rng)
        req, theta, scale = _required_damping(dev, k, b, whole)
        # the mp value at the reported angle, and no mp value on a fine grid above it
        assert abs(req - float(_mp_value(dev, k, b, whole, theta))) <= ROUNDING_BOUND * scale
        with mp.workdps(20):
            grid = np.linspace(1e-6, math.pi, 2000)
            top = max(float(_mp_value(dev, k, b, whole, float(x))) for x in grid)
        assert top <= req + 1e-9 * scale
    # B = 0, no delay: P(θ) = KT/2 for every θ, flat down to θ → 0: the rounding scale stays that of the value
    # (with the moduli of the complex products it was 1e7× larger at θ ≈ 1e-7: not checkable)
    dev = Device(mass=0.1, damping=3.0, sample_time=2.3e-4)
    req, theta, scale = _required_damping(dev, 25917.0, 0.0, 0)
    exact = 25917.0 * 2.3e-4 / 2
    assert abs(req - exact) <= ROUNDING_BOUND * scale and scale <= 2 * exact


@pytest.mark.parametrize("device, gm", [
    # a design with passivity active at 0 dB on B = 0: formerly the sup came from a grid point at θ ≈ 1e-7 with
    # a scale 1e7× the requirement (not checkable)
    (Device(mass=0.10007544715566916, damping=3.030064437369557, sample_time=0.00023382605418959898), 0.0),
    (Device(mass=3.0422398701803055, damping=0.9783751554524774, sample_time=0.003061319185774594), 6.0),
    (Device(mass=0.209121929339123, damping=2.0932730785523382e-05, sample_time=0.004028485182472716,
            delay=0.7208780576815753), 6.0),
    (Device(mass=1.1825859721484764, damping=5.15449740134149, sample_time=0.000187260507265711,
            delay=0.007177193088963022), 12.0),
])
def test_designs_on_their_passivity_constraint_are_confirmed(device, gm):
    """Designs from docs/properties_analysis.md that were not checkable with a 1e-9 back-off and tolerance."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        d = design_stiffness(device, StiffnessRequirements(min_gain_margin_db=gm, passivity=True))
    assert d.status == "optimal" and "passivity" in d.active_constraints
    v = verify_stiffness_design(device, d.stiffness, d.damping, d.gain_margin_db, True)
    assert v.verdict == "confirmed", v.reason
    assert v.passivity.physical_damping > v.passivity.required_damping
