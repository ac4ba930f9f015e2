"""Passivity (ARCHITECTURE.md delayed Colgate–Schenkel form) against independent computations.

Independent: the Dirichlet kernel as the explicit cosine sum 1 + 2Σcos(kθ) on a dense θ grid
(not the closed form the module uses), eq. 3 at d = 0, and b > K(T/2 + t_d) at B = 0.
"""

import math

import numpy as np
import pytest

from models.device import Device
from optim.stability.passivity import is_passive, largest_passive_stiffness, passivity_margin, passivity_samples

LH = Device(preset="lhifam").rigid()


def dense_largest_passive(device: Device, damping: float, d: int, n: int = 400_001) -> float:
    theta = np.linspace(1e-9, math.pi, n)
    s = 1 + 2 * sum(np.cos(k * theta) for k in range(1, d + 1))
    c = np.cos((d + 1) * theta)
    slack = device.damping + damping * c
    upper = np.min(np.where(s > 0, slack / (device.sample_time / 2 * np.where(s > 0, s, 1)), np.inf))
    lower = np.max(np.where(s < 0, slack / (device.sample_time / 2 * np.where(s < 0, s, -1)), -np.inf), initial=0)
    return float(upper) if upper > lower and upper > 0 else 0.0


@pytest.mark.slow
@pytest.mark.parametrize("delay_samples", [0, 1, 2, 3, 5])
@pytest.mark.parametrize("damping", [0.0, 0.5, 1.5, 3.0, 3.4])
def test_largest_passive_matches_dense_scan(delay_samples, damping):
    dev = LH.model_copy(update={"delay": delay_samples * LH.sample_time})
    got = largest_passive_stiffness(dev, damping).stiffness
    ref = dense_largest_passive(dev, damping, delay_samples)
    # the module refines the minimum continuously, so it is ≤ the grid's minimum and within the grid's
    # quadratic sampling error (Δθ ≈ 8e-6 rad) of it
    assert got <= ref * (1 + 1e-12) + 1e-9
    assert got == pytest.approx(ref, rel=1e-6, abs=1e-9)


@pytest.mark.parametrize("damping", [0.0, 0.7, 2.0, 3.49])
def test_eq3_without_delay(damping):
    """d = 0: b > KT/2 + B (chapter eq. 3) ⇒ K_max = (b − B)/(T/2)."""
    got = largest_passive_stiffness(LH, damping).stiffness
    assert got == pytest.approx((LH.damping - damping) / (LH.sample_time / 2), rel=1e-12)


@pytest.mark.parametrize("delay_samples", [0, 1, 2, 4, 7])
def test_no_virtual_damping_gives_b_over_half_T_plus_delay(delay_samples):
    dev = LH.model_copy(update={"delay": delay_samples * LH.sample_time})
    got = largest_passive_stiffness(dev, 0.0).stiffness
    assert got == pytest.approx(LH.damping / (LH.sample_time / 2 + dev.delay), rel=1e-12)


def test_fractional_delay_rounds_up_and_says_so():
    frac = LH.model_copy(update={"delay": 1.3e-3})
    whole = LH.model_copy(update={"delay": 2e-3})
    assert passivity_samples(frac) == (2, True)
    r = largest_passive_stiffness(frac, 1.0)
    assert r.conservative and r.delay_samples_used == 2
    assert r.stiffness == largest_passive_stiffness(whole, 1.0).stiffness


def test_delayed_form_differs_from_eq3():
    """FIELD-NOTES: with one sample of delay the delayed form is stricter than eq. 3 at B = 0."""
    dev = LH.model_copy(update={"delay": 1e-3})
    assert largest_passive_stiffness(dev, 0.0).stiffness < LH.damping / (LH.sample_time / 2) * 0.5


@pytest.mark.parametrize("delay_samples,damping", [(0, 1.0), (1, 1.0), (3, 2.0)])
def test_check_agrees_with_the_bound(delay_samples, damping):
    dev = LH.model_copy(update={"delay": delay_samples * LH.sample_time})
    k = largest_passive_stiffness(dev, damping).stiffness
    assert is_passive(dev, k * (1 - 1e-6), damping)
    assert not is_passive(dev, k * (1 + 1e-6), damping)
    assert passivity_margin(dev, k, damping).required_damping == pytest.approx(dev.damping, rel=1e-9)


def test_too_much_virtual_damping_is_not_passive():
    r = largest_passive_stiffness(LH, 5.0)          # B > b: eq. 3 fails for every K ≥ 0
    assert r.stiffness == 0.0 and r.reason
