"""The 40-digit reference rung (optim.stability.reference) where H passes close to the origin.

Near B_max, K_cr → 0: H(θ) = −1/G − β(1 − e^{−jθ}) passes just beside 0, and its two crossings there lie closer
together than the reference's fixed grid step (2.2e-3 rad at 118 samples of delay).  The reference answered 78.34
(the next crossover) where the exact rung and the closed loop say 2.398: the device of the bounded-scan test's
generator (tests/optim/stability/test_fast_cable.py, seed 20, i = 41, B = 0.99982·B_max).  The check is the
closed loop in physical coordinates (tests/optim/independent.py), which shares no code with either scan.
"""

from __future__ import annotations

import math

import mpmath as mp
import pytest

from models.device import Device
from optim.stability.margins import critical_stiffness
from optim.stability.reference import _scan, reference_critical_stiffness
from tests.optim.independent import spectral_radius

NEAR_B_MAX = Device(mass=0.30353914835456997, sample_time=0.002, delay=0.23600000000000002, cable=dict(
    motor_mass=0.04660041892610148, motor_damping=6.9359209334340015, body_mass=0.2569387294284685,
    body_damping=24.202034048526805, stiffness=290.03938023218063, damping=6.3655877592470675))
B = 13.378371996632074          # 0.99982·B_max (B_max = 13.38075 N·s/m)


@pytest.mark.slow
def test_reference_finds_the_crossover_pair_near_b_max():
    ref = reference_critical_stiffness(NEAR_B_MAX, B, digits=20)     # 20 digits: 18 s instead of 46 s
    exact = critical_stiffness(NEAR_B_MAX, B)
    # K_cr ∝ B_max − B here: the exact rung's rounding is ~ε·B/(B_max − B) relative (test_fast_cable.py)
    assert ref.critical_stiffness == pytest.approx(exact.critical_stiffness, rel=1e-10)
    assert ref.crossover_frequency == pytest.approx(exact.crossover_frequency, rel=1e-10)
    # the pair's partner has K < 0 and is not listed: the next crossover is the old answer, 78.34
    assert sorted(k for _, k in ref.crossovers)[1] == pytest.approx(78.33996080991184, rel=1e-10)
    m, t = NEAR_B_MAX.mass, NEAR_B_MAX.sample_time
    beta = B * t / m

    def rho(k: float) -> float:
        return spectral_radius(NEAR_B_MAX, k * t * t / m, beta)

    k = ref.critical_stiffness
    assert rho(k * 0.999) < 1.0 < rho(k * 1.001)
    assert rho(78.34 * 0.99) > 1.0          # the old answer: already unstable below it


def test_scan_brackets_two_crossings_within_one_grid_step():
    """A synthetic H with its pair of crossings (θ0 ∓ w, K = ±w) between two neighbouring samples of the
    reference's linear grid (118 samples of delay: step π/(12·119)), where arg H turns by π: found, K = w."""
    dev = Device(mass=1.0, damping=1.0, sample_time=1e-3, delay=0.118)
    step_n = int(math.ceil((math.pi - 0.05) / min(0.01, math.pi / (12 * 119))))
    grid = [0.05 + (math.pi - 0.05) * i / step_n for i in range(1, step_n + 1)]
    i = next(k for k, p in enumerate(grid) if p > 0.13)
    theta0, w = 0.5 * (grid[i] + grid[i + 1]), 0.25 * (grid[i + 1] - grid[i])

    def h(theta):
        x = theta - theta0
        return mp.mpc(1, 0) * (-x) + mp.mpc(0, 1) * (x * x - w * w) * (1 + theta)

    found = _scan(h, dev, 0.0, 20)
    assert len(found) == 1
    assert found[0][0] == pytest.approx(theta0 - w, rel=1e-12)
    assert found[0][1] == pytest.approx(w, rel=1e-9)
