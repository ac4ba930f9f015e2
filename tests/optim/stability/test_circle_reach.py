"""optim.stability.circle_reach / closed_loop_mp: verify never reads a pole's side from rounding (issue 34).

References: the issue's audit (50-digit Newton root tracking on the plant's own exact ZOH: the binding pole of the
device below at |z| − 1 = ∓2.1e-17 at K_cr·(1 ∓ 1e-6), docs/properties_analysis.md "Cable fast path"); a
synthetic return difference (1 − q/z)(1 − q̄/z) whose zeros q, q̄ are placed 1e-20 off the circle in mpmath;
mpmath's own matrix exponential for the mpmath plant.
"""

from __future__ import annotations

import cmath

import mpmath as mp
import numpy as np
import pytest

from models.device import Device
from optim.stability.closed_loop import count_outside, sampled_plant, unstable_count
from optim.stability.closed_loop_mp import _continuous, _psi, mp_plant, mp_return_difference
from optim.verification import verify_critical_stiffness

# docs/properties_analysis.md, "Cable fast path": the one of 5,000 random damped cables verify called "contradicted"
ISSUE_DEVICE = {"mass": 9.227630257484549, "damping": 1.1926948188747691e-05, "sample_time": 0.002,
                "delay": 0.32703054165799533,
                "cable": {"motor_mass": 7.921220758518302, "motor_damping": 9.040275316094e-06,
                          "body_mass": 1.3064094989662465, "body_damping": 2.8866728726536906e-06,
                          "stiffness": 1851106.8878295596, "damping": 6.197968509007329e-05}}
ISSUE_B = 0.03140229565265541
ISSUE_KCR = 0.004531914500498841          # zwidth's answer, 0.0045319145 N/m (right: the audit's root tracking)


def _alpha_beta(dev: Device, k: float, b: float) -> tuple[float, float]:
    m, t = dev.mass, dev.sample_time
    return k * t * t / m, b * t / m


def test_the_issue_device_is_confirmed_not_contradicted():
    dev = Device.model_validate(ISSUE_DEVICE)
    v = verify_critical_stiffness(dev, ISSUE_B, ISSUE_KCR)
    assert v.verdict == "confirmed", v
    assert (v.unstable_poles_below, v.unstable_poles_above) == (0, 2)
    assert "mpmath" in v.method and "below double precision's reach" in v.method


@pytest.mark.parametrize("sign, outside", [(-1, 0), (1, 2)])
def test_the_crossing_pole_sits_where_the_audit_found_it(sign, outside):
    dev = Device.model_validate(ISSUE_DEVICE)
    plant = sampled_plant(dev)
    a, b = _alpha_beta(dev, ISSUE_KCR * (1 + sign * 1e-6), ISSUE_B)
    # double precision alone reads the count from rounding there: 0 outside at K_cr·(1 + 1e-6) (the old verdict)
    assert unstable_count(dev, plant, a, b).count == 0
    cnt = unstable_count(dev, plant, a, b, mp_return_difference(dev, a, b))
    assert cnt.count == outside
    # the note names the pole's offset: the audit's ∓2.1e-17
    off = float(cnt.precise.split("a pole ")[1].split(" off")[0])
    assert off == pytest.approx(sign * 2.1e-17, rel=0.05)


def test_a_wrong_answer_on_the_issue_device_is_still_contradicted():
    dev = Device.model_validate(ISSUE_DEVICE)
    for wrong in (ISSUE_KCR * 1.01, ISSUE_KCR * 0.99):
        assert verify_critical_stiffness(dev, ISSUE_B, wrong).verdict == "contradicted"


def _synthetic(r: float):
    """F = (1 − q/z)(1 − q̄/z), q = (1 + r)·e^{0.7j}: zeros 1e-20-ish off the circle, double poles at z = 0."""
    theta_q = 0.7

    def dbl(th: np.ndarray) -> np.ndarray:
        q = (1.0 + r) * cmath.exp(1j * theta_q)
        w = np.exp(-1j * th)
        return (1 - q * w) * (1 - np.conj(q) * w)

    def precise(th):
        with mp.workdps(60):
            q = (1 + mp.mpf(r)) * mp.expj(mp.mpf(theta_q))
            w = mp.expj(-th)
            return (1 - q * w) * (1 - mp.conj(q) * w)
    return dbl, precise


@pytest.mark.parametrize("r, outside", [(1e-20, 2), (-1e-20, 0), (3e-3, 2), (-3e-3, 0)])
def test_a_pole_1e_20_off_the_circle_is_placed_in_mpmath(r, outside):
    dbl, precise = _synthetic(r)
    poles = np.zeros(2, dtype=complex)
    cnt = count_outside(dbl, poles, 0, 0, (), precise, 50)
    assert cnt.count == outside, cnt
    assert (cnt.precise is not None) == (abs(r) < 1e-8)


def test_a_pole_on_the_circle_is_not_decided():
    dbl, precise = _synthetic(0.0)
    cnt = count_outside(dbl, np.zeros(2, dtype=complex), 0, 0, (), precise, 50)
    assert cnt.count is None and "rounding of the unit circle" in cnt.reason


def test_the_mpmath_plant_agrees_with_the_double_one_and_mpmaths_exponential():
    dev = Device.model_validate(ISSUE_DEVICE)
    p, d = mp_plant(dev), sampled_plant(dev)
    assert np.abs(np.array(p.e.tolist(), dtype=float) - d.e).max() < 1e-13
    assert np.abs(np.array(p.g0.tolist(), dtype=float).ravel() - d.g0).max() < 1e-13
    assert np.abs(np.array(p.g1.tolist(), dtype=float).ravel() - d.g1).max() < 1e-13
    with mp.workdps(60):
        a, _ = _continuous(dev)
        phi, psi = _psi(a, mp.mpf("0.37"))
        big = mp.zeros(8, 8)
        for i in range(4):
            for j in range(4):
                big[i, j] = a[i, j] * mp.mpf("0.37")
            big[i, 4 + i] = mp.mpf("0.37")
        ref = mp.expm(big)
        assert mp.mnorm(phi - ref[0:4, 0:4], 1) < mp.mpf(10) ** -50
        assert mp.mnorm(psi - ref[0:4, 4:8], 1) < mp.mpf(10) ** -50
