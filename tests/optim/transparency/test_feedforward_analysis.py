"""Critical force-feedforward gain (chapter §5, eq. 29-34) against the chapter and independent methods."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from models.device import Device
from models.feedforward import CHAPTER_HUMAN, feedforward_plant
from models.filters import ButterworthLowPass
from optim.transparency.feedforward import apparent_mass, critical_force_gain, worst_case_force_gain
from optim.transparency.feedforward_reference import reference_g1
from tests.feedforward_reference import (
    EQ32_CRITICAL_FORCE_GAIN,
    EQ32_RTOL,
    EQ33_WORST_CASE,
    HUMAN_EQ30,
    LHIFAM_CABLE,
    LHIFAM_RIGID,
    SEC52_APPARENT_MASS,
    SEC52_FORCE_GAIN,
    SENSOR_EQ31,
)
from tests.optim.closed_loop import closed_loop_matrix, spectral_radius


def with_(device: Device, **update) -> Device:
    """A validated copy with some fields replaced (model_copy would skip validation)."""
    return Device.model_validate({**device.model_dump(exclude={"preset"}), **update})


RIGID = Device(**LHIFAM_RIGID, human=HUMAN_EQ30, force_sensor=SENSOR_EQ31)
CABLE = Device(**LHIFAM_CABLE, human=HUMAN_EQ30, force_sensor=SENSOR_EQ31)


def test_eq32_critical_force_gain_at_nyquist():
    r = critical_force_gain(RIGID)
    assert r.critical_force_gain == pytest.approx(EQ32_CRITICAL_FORCE_GAIN, rel=EQ32_RTOL)
    # The crossover is the Nyquist point itself (found by symmetry, exactly π/T).
    assert r.crossover_frequency == pytest.approx(math.pi / RIGID.sample_time, rel=1e-15)
    assert len(r.crossovers) == 1


def test_eq33_worst_case_and_apparent_mass():
    assert worst_case_force_gain(RIGID, CHAPTER_HUMAN) == pytest.approx(EQ33_WORST_CASE, rel=1e-15)
    assert critical_force_gain(RIGID).worst_case_force_gain == pytest.approx(EQ33_WORST_CASE, rel=1e-15)
    assert apparent_mass(RIGID, SEC52_FORCE_GAIN) == pytest.approx(SEC52_APPARENT_MASS, rel=1e-15)


def test_eq33_is_the_large_delay_limit():
    """Eq. 33 is 'approximately' the worst K_f,cr for large delays: with 0.1 s of delay
    the crossover lies between the grasp (~2 rad/s) and the sensor (200 rad/s), where
    |G_1| ≈ m_h/(m + m_h); 5 % covers the grasp's and the sensor's residual gain there."""
    r = critical_force_gain(with_(RIGID, delay=0.1))
    assert r.critical_force_gain == pytest.approx(EQ33_WORST_CASE, rel=0.05)
    assert r.critical_force_gain < critical_force_gain(RIGID).critical_force_gain


def test_human_default_is_eq30_and_said_so():
    r = critical_force_gain(Device(**LHIFAM_RIGID, force_sensor=SENSOR_EQ31))
    assert r.human == CHAPTER_HUMAN and "eq. 30" in r.human_source
    assert r.critical_force_gain == critical_force_gain(RIGID).critical_force_gain
    assert critical_force_gain(RIGID).human_source == "device"


CASES = [
    # (device, filter (cutoff Hz, order) or None, delay [s], sensor time constant [s])
    (RIGID, None, 0.0, 0.005),
    (RIGID, None, 0.0, 0.0),            # no sensor filter: direct term through u[k-d-1]
    (RIGID, None, 0.00037, 0.005),      # fractional delay
    (RIGID, None, 0.003, 0.005),
    (RIGID, (30.0, 2), 0.0, 0.005),
    (RIGID, (10.0, 4), 0.0, 0.005),
    (RIGID, (120.0, 1), 0.0012, 0.0),
    (RIGID, (45.0, 3), 0.0025, 0.002),
    (CABLE, None, 0.0, 0.005),
    (CABLE, None, 0.00025, 0.005),
    (CABLE, (30.0, 2), 0.0, 0.005),
    (CABLE, (60.0, 4), 0.0, 0.0),
    (CABLE, (20.0, 1), 0.002, 0.005),
    (CABLE, (82.0, 3), 0.0007, 0.001),
]


@pytest.mark.parametrize("device, filt, delay, tf", CASES)
def test_critical_force_gain_is_where_closed_loop_poles_cross_the_unit_circle(device, filt, delay, tf):
    """Spectral radius of the closed-loop matrix (scipy's Butterworth realisation, the delay
    chain, Φ, Γ0, Γ1, C): < 1 just below K_f,cr and > 1 just above, to 1e-6 relative."""
    dev = with_(device, delay=delay, force_sensor={"time_constant": tf})
    f = ButterworthLowPass(filt[1], filt[0], dev.sample_time) if filt else None
    r = critical_force_gain(dev, f)
    kcr = r.critical_force_gain
    assert math.isfinite(kcr) and kcr > 0
    plant = feedforward_plant(dev, dev.human)
    below, above = spectral_radius(plant, kcr * (1 - 1e-6), f), spectral_radius(plant, kcr * (1 + 1e-6), f)
    assert below < 1.0 < above, (below, above)
    # and the pole that crosses sits at the reported crossover angle
    lam = np.linalg.eigvals(closed_loop_matrix(plant, kcr, f))
    on_circle = lam[np.argmin(np.abs(np.abs(lam) - 1.0))]
    assert abs(abs(np.angle(on_circle)) - r.crossover_frequency * dev.sample_time) <= 1e-6


def test_no_sensor_filter_is_the_limit_of_a_fast_one():
    """T_f → 0⁺ of the filtered model equals the T_f = 0 model with the kT⁻ sampling convention."""
    k0 = critical_force_gain(with_(RIGID, force_sensor=None)).critical_force_gain
    k1 = critical_force_gain(with_(RIGID, force_sensor={"time_constant": 1e-9})).critical_force_gain
    assert k1 == pytest.approx(k0, rel=1e-5)  # O(T_f/T) = 1e-6 difference expected


@pytest.mark.parametrize("device", [RIGID, CABLE], ids=["rigid", "cable"])
@pytest.mark.parametrize("delay", [0.0, 0.00137])
def test_discretisation_matches_residues_in_extended_precision(device, delay):
    dev = with_(device, delay=delay)
    plant = feedforward_plant(dev, dev.human)
    thetas = [1e-3, 0.02, 0.3, 0.52, 1.7, 3.0, math.pi]
    ours = plant.response(np.array(thetas))
    for th, g in zip(thetas, ours):
        ref = reference_g1(dev, dev.human, th)     # 40-digit residues, optim/transparency/feedforward_reference.py
        # expm-based Φ, Γ carry ~1e-13 relative error; 1e-9 leaves room for the resolvent's conditioning
        assert abs(g - ref) <= 1e-9 * abs(ref), (th, g, ref)


@settings(max_examples=25, deadline=None)
@given(scale_m=st.floats(0.01, 100.0), scale_t=st.floats(0.1, 10.0))
def test_invariant_under_the_dimensionless_scalings(scale_m, scale_t):
    """K_f is dimensionless: scaling every mass by λ (and dampings, stiffnesses with it) and
    time by τ (b ∝ m/τ, k ∝ m/τ²) leaves K_f,cr and ωT unchanged."""
    base = critical_force_gain(with_(RIGID, delay=0.0013), ButterworthLowPass(2, 30.0, 1e-3))
    lm, lt = scale_m, scale_t
    dev = Device(mass=5.4 * lm, damping=3.5 * lm / lt, sample_time=1e-3 * lt, delay=0.0013 * lt,
                 human={"mass": 2 * lm, "damping": 2 * lm / lt, "stiffness": 10 * lm / lt**2},
                 force_sensor={"time_constant": 0.005 * lt})
    r = critical_force_gain(dev, ButterworthLowPass(2, 30.0 / lt, 1e-3 * lt))
    assert r.critical_force_gain == pytest.approx(base.critical_force_gain, rel=1e-9)
    assert r.crossover_frequency * dev.sample_time == pytest.approx(base.crossover_frequency * 1e-3, rel=1e-9)


def test_filter_sample_time_must_match():
    with pytest.raises(ValueError, match="filter"):
        critical_force_gain(RIGID, ButterworthLowPass(2, 30.0, 2e-3))


@pytest.mark.parametrize("device", [RIGID, CABLE], ids=["rigid", "cable"])
def test_very_low_cutoff_fourth_order_limit(device):
    """Closed-form limit: a 4th-order Butterworth has phase -180° and gain 1/√2 exactly at its
    cutoff; with a cutoff far below every plant feature (0.001 Hz) G_1 ≈ G_1(1) = 1 there, so
    K_f,cr → √2.  The residual is the grasp's phase/gain at 0.006 rad/s (measured 1.2e-3)."""
    r = critical_force_gain(device, ButterworthLowPass(4, 0.001, device.sample_time))
    assert r.critical_force_gain == pytest.approx(math.sqrt(2), rel=5e-3)
    assert r.crossover_frequency == pytest.approx(2 * math.pi * 0.001, rel=5e-3)
