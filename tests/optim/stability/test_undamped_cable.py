"""Cables with every damping 0 (optim.stability.undamped_cable): no answer confident and wrong.

The four devices the 10,000-device verify run contradicted (docs/properties_analysis.md, seed 17) and random
neighbours.  Each answer is held to closed-loop eigenvalues in 50-digit mpmath (tests/optim/independent.py
radius_excess_mp: physical coordinates, its own discretisation), never to the code that produced it; a refusal
(InputError on device.cable, a 422 over HTTP) is allowed, a wrong number is not.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from models.device import Device
from optim.errors import InputError
from optim.stability.analysis import analyse_stability
from optim.stability.margins import critical_stiffness, max_stable_damping, scan_critical_stiffness
from tests.optim.independent import radius_excess_mp

EPS = 1e-6


def _cable(t: float, d: float, mr: float, md: float, k: float) -> Device:
    return Device(sample_time=t, delay=d * t, cable=dict(motor_mass=mr, body_mass=md, stiffness=k, motor_damping=0.0,
                                                          body_damping=0.0, damping=0.0))


# (device, B [N·s/m] of the run): the run's B came from a B_max of 1e16–1e18 read off rounding at z = −1
FOUR = [
    (_cable(0.006250402057254943, 0, 0.16040457457971422, 1.0449542378107328, 13031.71187436239), 4.673679512438441e16),
    (_cable(7.999796928089975e-05, 0, 2.8747431681893, 10.108263979549685, 20531391.930824228), 25919.15997981818),
    (_cable(0.0037715479863110707, 0, 11.561740587855498, 12.40907449239514, 1655802.144700532), 3.0825311342460913e18),
    (_cable(0.005646707183082924, 1, 3.3413367975414854, 5.235151006747069, 78711.30622673624), 5.2755315246837544e16),
]


def _small_k(dev: Device, b: float) -> float:
    return 1e-6 * b / (dev.sample_time / 2 + dev.delay)


def _holds(dev: Device, b: float, kcr: float) -> None:
    """K_cr = kcr against the mpmath closed loop: unstable at a small K for 0; otherwise stable at K(1 − ε), unstable
    at K(1 + ε); inf: stable at 100× the linear estimate (no finite set proves it; a probe can refute it)."""
    if kcr == 0.0:
        assert radius_excess_mp(dev, _small_k(dev, b), b) > 0
    elif math.isinf(kcr):
        assert radius_excess_mp(dev, 100 * b / (dev.sample_time / 2 + dev.delay), b) < 0
    else:
        assert radius_excess_mp(dev, kcr * (1 - EPS), b) < 0 < radius_excess_mp(dev, kcr * (1 + EPS), b), kcr


@pytest.mark.parametrize("i", range(4))
def test_the_four_contradicted_devices(i):
    dev, b = FOUR[i]
    res = critical_stiffness(dev, b)
    _holds(dev, b, res.critical_stiffness)
    assert scan_critical_stiffness(dev, b).critical_stiffness == res.critical_stiffness
    if i == 1:
        # d = 0, θ_n = 0.24: B damps the cable mode; B_max = 70,495 N·s/m (the crossover at θ = π/2, where the
        # delay-free damper loop is real), not 25,883 (the rounded value of H at z = −1, a zero of G)
        assert res.critical_stiffness == pytest.approx(2.944930876856617e8, rel=1e-9)
        b_max = max_stable_damping(dev)
        assert b_max == pytest.approx(70495.0394744101, rel=1e-9)
        assert radius_excess_mp(dev, _small_k(dev, b_max), b_max * (1 - 1e-4)) < 0
        assert radius_excess_mp(dev, _small_k(dev, b_max), b_max * (1 + 1e-4)) > 0
    else:
        # θ_n(d + 1) > π/2: the damper's lag drives the cable mode out at any B > 0, however small
        assert res.critical_stiffness == 0.0 and "outwards" in res.reason
        assert max_stable_damping(dev) == 0.0
        for frac in (1e-6, 1e-3, 1.0):
            bb = frac * dev.damping_scale
            assert critical_stiffness(dev, bb).critical_stiffness == 0.0
            assert radius_excess_mp(dev, _small_k(dev, bb), bb) > 0


def test_no_virtual_damping_is_k_cr_zero_as_for_a_rigid_mass_without_damping():
    dev, _ = FOUR[1]
    assert critical_stiffness(dev, 0.0).critical_stiffness == 0.0
    assert radius_excess_mp(dev, 1e-3, 0.0) > 0


def _random_undamped(rng: np.random.Generator) -> Device:
    t = 10 ** rng.uniform(-4.5, -2)
    m = 10 ** rng.uniform(-1, 1.5)
    d = float(rng.integers(0, 6)) if rng.random() < 0.6 else rng.uniform(0, 6)
    mr = m * rng.uniform(0.05, 0.5)
    wn = min(10 ** rng.uniform(1, 4), rng.uniform(0.5, 0.95) * math.pi / t)
    return _cable(t, d, mr, m - mr, wn ** 2 * mr * (m - mr) / m)


@pytest.mark.slow
def test_random_undamped_cables_against_mpmath():
    """60 neighbours: delays 0–6 samples (whole and fractional), modes up to 0.95·Nyquist, B log-uniform over six
    decades and uniform up to 1.05·B_max."""
    rng = np.random.default_rng(1717)
    answered = refused = 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        for i in range(60):
            dev = _random_undamped(rng)
            beta = 10 ** rng.uniform(-6, 0) / (1 + 2 * dev.delay_samples)
            b = beta * dev.damping_scale
            if i % 2:
                try:
                    b_max = max_stable_damping(dev)
                except InputError:
                    b_max = math.inf
                if 0 < b_max < math.inf:
                    b = b_max * rng.uniform(0, 1.05)
            try:
                kcr = critical_stiffness(dev, b).critical_stiffness
            except InputError as exc:
                assert exc.field == "device.cable" and "every cable damping 0" in exc.rule
                refused += 1
                continue
            answered += 1
            _holds(dev, b, kcr)
    assert answered >= 50, (answered, refused)


def test_analysis_refuses_with_the_field_or_answers():
    """Over the analysis (a 422 on HTTP): the along-the-circle departure (ω_n T = 0.9π, d = 4: cos 4.5π = 0)
    needs B to decide; B_max alone is refused, naming device.cable."""
    t = 1e-3
    dev = _cable(t, 4, 0.2, 0.8, (0.9 * math.pi / t) ** 2 * 0.2 * 0.8 / 1.0)
    with pytest.raises(InputError) as exc:
        max_stable_damping(dev)
    assert exc.value.field == "device.cable"
    try:
        a = analyse_stability(dev, damping=1e-3 * dev.damping_scale)
    except InputError as e:
        assert e.field == "device.cable"
    else:
        _holds(dev, a.damping, a.critical_stiffness if a.critical_stiffness is not None else math.inf)


# issue 34: a cable with every damping 0 past its B_max (random_cable(default_rng([34, 32]), 32, top=12, undamped=…),
# B 20 % or so above B_max): the scan's "no positive stiffness is stable" was false; the band analysis (the scan's
# true crossings, each interval counted by the closed loop) reports a band, which the independent closed loop holds
UNDAMPED_BAND = {"mass": 0.013212882726801545, "damping": 0.0, "sample_time": 0.001, "delay": 0.003596900373757159,
                 "cable": {"motor_mass": 0.009959895922005543, "motor_damping": 0.0,
                           "body_mass": 0.003252986804796002, "body_damping": 0.0,
                           "stiffness": 2524.489818085512, "damping": 0.0}}
UNDAMPED_BAND_B = 0.18251129511810674


def test_undamped_cable_past_b_max_reports_its_stable_band():
    from tests.optim.independent import spectral_radius

    dev = Device(**UNDAMPED_BAND)
    assert UNDAMPED_BAND_B > max_stable_damping(dev)
    a = analyse_stability(dev, None, UNDAMPED_BAND_B)
    assert a.critical_stiffness == 0.0 and a.stable_band is not None
    lo, hi = a.stable_band
    assert lo == pytest.approx(12.09111202611472, rel=1e-6) and hi == pytest.approx(43.363986733657605, rel=1e-6)
    t, m = dev.sample_time, dev.mass

    def excess(k: float) -> float:
        return spectral_radius(dev, k * t * t / m, UNDAMPED_BAND_B * t / m) - 1.0

    assert excess(math.sqrt(lo * hi)) < 0.0
    assert excess(lo * (1 - 1e-4)) > 0.0 and excess(lo * (1 + 1e-4)) < 0.0
    assert excess(hi * (1 - 1e-4)) < 0.0 and excess(hi * (1 + 1e-4)) > 0.0
    assert analyse_stability(dev, math.sqrt(lo * hi), UNDAMPED_BAND_B).stable is True
