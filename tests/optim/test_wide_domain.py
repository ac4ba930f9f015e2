"""The exact and grid rungs over the whole documented δ domain (docs/limits.md: δ = 0 or 1e-30 … 1e9), beyond the
1e-10 … 1 of the main property runs (tests/optim/verify_cases.py, bench/bench_verify.py).

What the first probe of this range found (2026-12-01): the grid's Nyquist-sample answer 1 ulp outside an estimate
of 0 (δ ≈ 2e3), and two near-lossless cables whose scan answer the closed loop contradicts (now refused,
tests/optim/stability/test_near_lossless_cable.py).  Verdicts: confirmed, or not checkable where double precision
cannot decide (verify says so), or a 422 — never contradicted; the grid within its estimate or null.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from models.device import Device
from optim.errors import InputError
from optim.stability.analysis import analyse_stability
from optim.stability.margins import max_stable_damping
from optim.verification import verify_analysis

pytestmark = pytest.mark.slow


def _device(rng: np.random.Generator) -> Device:
    t, m = 10 ** rng.uniform(-4.5, -2), 10 ** rng.uniform(-1, 1.5)
    delta = 10 ** (rng.uniform(-30, -10) if rng.random() < 0.5 else rng.uniform(0, 9))
    delta = min(delta, 0.99e12 * t / m)                        # damping ≤ 1e12 (SI)
    d = [0.0, float(rng.integers(1, 6)), rng.uniform(0, 40), rng.uniform(0, 400)][rng.integers(0, 4)]
    b0 = delta * m / t
    if rng.random() < 0.5:
        return Device(mass=m, damping=b0, sample_time=t, delay=d * t)
    mr = m * rng.uniform(0.05, 0.5)
    md = m - mr
    wn = min(10 ** rng.uniform(1, 4), 0.9 * math.pi / t)
    br = b0 * rng.uniform(0, 1)
    bc = min(10 ** rng.uniform(-30, 6) * m / t, 0.99e12)
    return Device(sample_time=t, delay=d * t, cable=dict(motor_mass=mr, body_mass=md, motor_damping=br,
                                                         body_damping=b0 - br, stiffness=wn ** 2 * mr * md / m,
                                                         damping=bc))


def test_no_contradicted_answer_and_the_grid_within_its_estimate():
    rng = np.random.default_rng(2)
    confirmed = 0
    for _ in range(150):
        dev = _device(rng)
        try:
            b = 0.0
            if rng.random() < 0.5:
                bm = max_stable_damping(dev)
                b = bm * rng.uniform(0, 1.05) if math.isfinite(bm) else 0.0
            a = analyse_stability(dev, damping=b)
        except InputError:
            continue
        v = verify_analysis(dev, a)
        assert v.verdict != "contradicted", (dev, b, a.critical_stiffness, v.reason)
        confirmed += v.verdict == "confirmed"
        g = analyse_stability(dev, damping=b, method="grid")
        if g.error_estimate is not None and math.isfinite(g.error_estimate):
            k, exact = g.critical_stiffness, a.critical_stiffness
            assert (k == exact == 0.0) or abs(k / exact - 1) <= g.error_estimate, (dev, b, k, exact, g.error_estimate)
    assert confirmed >= 90


def test_near_lossless_rigid_devices_agree_with_the_reference():
    """δ 1e-28 … 1e-12 (rigid): verify is often not_checkable there (poles within rounding of the circle), so the
    exact rung is held to the 30-digit reference instead: ≤ 6.7e-16 on these 12 (probe of 2026-12-02)."""
    from optim.stability.margins import critical_stiffness
    from optim.stability.reference import reference_critical_stiffness

    rng = np.random.default_rng(11)
    for _ in range(12):
        t, m = 10 ** rng.uniform(-4.5, -2), 10 ** rng.uniform(-1, 1.5)
        delta = 10 ** rng.uniform(-28, -12)
        d = float(rng.integers(0, 8)) + (0.5 if rng.random() < 0.3 else 0)
        dev = Device(mass=m, damping=delta * m / t, sample_time=t, delay=d * t)
        b = 0.0 if rng.random() < 0.5 else max_stable_damping(dev) * rng.uniform(0, 0.9)
        exact = critical_stiffness(dev, b).critical_stiffness
        ref = reference_critical_stiffness(dev, b, digits=30).critical_stiffness
        assert exact == pytest.approx(ref, rel=1e-12), (dev, b, exact, ref)
