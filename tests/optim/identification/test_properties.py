"""Property tests: exact data of random rigid devices (mass, δ = bT/m, delay up to the default search range of
20 samples, T) are recovered to near machine precision, by the response fit and the time-series fit; the
exact sampled model agrees with the scene simulator's independent SI construction."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from models.device import Device
from optim.identification import FrequencyResponseData, TimeSeriesData, identify
from optim.identification.models import response, simulate_position
from tests.optim.identification.synthetic import CABLE, excitation, simulate_experiment

devices = st.builds(
    lambda m, delta, d, t: Device(mass=m, damping=delta * m / t, delay=d * t, sample_time=t),
    st.floats(0.01, 100.0), st.floats(1e-4, 0.1), st.floats(0.0, 19.5), st.sampled_from([1e-3, 2.5e-4, 1e-4]))


@pytest.mark.slow
@settings(max_examples=25, deadline=None, derandomize=True)
@given(devices)
def test_exact_response_is_recovered(dev):
    t = dev.sample_time
    w = np.geomspace(1e-3 / t, 0.5 / t, 40)
    res = identify(FrequencyResponseData(w, response(dev, w, "continuous"), t), model="rigid")
    p = res.parameters
    assert res.status == "identified", res.reason
    assert p["mass"].value == pytest.approx(dev.mass, rel=1e-6)
    assert p["damping"].value == pytest.approx(dev.damping, rel=1e-4)
    assert abs(p["delay"].value - dev.delay) <= 1e-6 * t


@pytest.mark.slow
@settings(max_examples=8, deadline=None, derandomize=True)
@given(devices)
def test_exact_record_is_recovered(dev):
    t = dev.sample_time
    u = excitation(3000, t, amplitude=1.0, seed=3, f1=0.2 / t)
    y = simulate_position(dev, u)
    res = identify(TimeSeriesData(t, u, y + 0.01), model="rigid")
    p = res.parameters
    assert res.status == "identified", (dev, res.warnings)
    # a delay at its bound 0 is tried as active (fit._polish_at_bounds): without that, trust-region
    # reflective stopped short of it where the OpenBLAS kernel decided (issue 29: mass 2e-5 off, delay 2.5e-4
    # samples on Haswell, 4.5e-6 / 7.6e-5 on SkylakeX).  Reached on both kernels: ≤ 2e-13 relative on the
    # mass and damping at a delay bound, ≤ 7e-10 inside (m = 23, δ = 0.03, 0.14 samples: the Jacobian's central
    # differences are 1e-10 accurate); 1e-8 leaves room for the kernels' rounding, 2,000× tighter than before
    assert p["mass"].value == pytest.approx(dev.mass, rel=1e-8)
    assert p["damping"].value == pytest.approx(dev.damping, rel=1e-8)
    assert abs(p["delay"].value - dev.delay) <= 1e-7 * t


@settings(max_examples=15, deadline=None, derandomize=True)
@given(st.floats(0.0, 7.9), st.booleans())
def test_model_matches_the_scene_simulator(d, cable):
    """optim's modal-form simulation (dimensionless RigidZOH / StateSpaceZOH) and the scene simulator's SI
    matrices stepped sample by sample are two constructions of the same exact sampled model."""
    dev = Device(**CABLE, delay=d * 1e-3) if cable else Device(mass=5.4, damping=3.5, delay=d * 1e-3)
    u = excitation(600, 1e-3, seed=int(d * 10))
    a, b = simulate_position(dev, u), simulate_experiment(dev, u)
    assert np.max(np.abs(a - b)) <= 1e-10 * np.max(np.abs(b))
