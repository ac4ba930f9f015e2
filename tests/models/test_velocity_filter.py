"""The velocity filters of the rendered wall (models.velocity_filter): each kind's V(z) against its definition
evaluated independently (scipy.signal.freqz of the N/D form written out from ARCHITECTURE.md's table), and every
refusal naming its field."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydantic import ValidationError
from scipy import signal

from models.errors import InputError
from models.velocity_filter import (
    DEFAULT_RENDERING,
    BackwardDifference,
    LowPass,
    MovingAverage,
    TransferFunctionFilter,
    rendering,
    velocity_transfer,
)

T = 1e-3
THETA = np.concatenate([np.geomspace(1e-6, 0.1, 40), np.linspace(0.1, math.pi, 200)])


def _freqz(num, den, theta):
    """T·V(e^{jθ}) by scipy.signal.freqz (num, den in ascending powers of z⁻¹, num in 1/s)."""
    _, h = signal.freqz(np.asarray(num) * T, den, worN=theta)
    return h


@pytest.mark.parametrize("spec,num,den", [
    (BackwardDifference(), [1 / T, -1 / T], [1.0]),
    (LowPass(kind="low_pass", cutoff_hz=50.0, order=1),
     np.array([1.0, -1.0]) * (1 - math.exp(-2 * math.pi * 50 * T)) / T, [1.0, -math.exp(-2 * math.pi * 50 * T)]),
    (MovingAverage(kind="moving_average", samples=5), [1 / (5 * T), 0, 0, 0, 0, -1 / (5 * T)], [1.0]),
])
def test_each_kind_is_its_definition(spec, num, den):
    v = velocity_transfer(spec, T).response(THETA)
    np.testing.assert_allclose(v, _freqz(num, den, THETA), rtol=1e-9, atol=1e-15)


def test_second_order_low_pass_is_the_butterworth_after_the_backward_difference():
    b, a = signal.butter(2, 80.0, fs=1 / T)
    v = velocity_transfer(LowPass(kind="low_pass", cutoff_hz=80.0, order=2), T).response(THETA)
    np.testing.assert_allclose(v, _freqz(np.polymul([1, -1], b) / T, a, THETA), rtol=1e-8, atol=1e-14)
    # unit DC gain: V ≈ jθ/T at low frequency (V'(1)·T = 1)
    np.testing.assert_allclose(v[:5] / (1j * THETA[:5]), 1.0, rtol=1e-4)


def test_transfer_function_equals_the_same_filter_given_as_its_kind():
    a = math.exp(-2 * math.pi * 30 * T)
    spec = TransferFunctionFilter(kind="transfer_function", numerator=[2 * (1 - a) / T, -2 * (1 - a) / T],
                                  denominator=[2.0, -2 * a])   # D(0) ≠ 1: normalised
    np.testing.assert_allclose(velocity_transfer(spec, T).response(THETA),
                               velocity_transfer(LowPass(kind="low_pass", cutoff_hz=30.0), T).response(THETA),
                               rtol=1e-12)


def test_small_angles_keep_their_precision():
    # 1 − e^{−jθ} through expm1: at θ = 1e-9 rad the backward difference is jθ + θ²/2 to full precision
    v = velocity_transfer(None, T).response(np.array([1e-9]))[0]
    assert v.imag == pytest.approx(1e-9, rel=1e-15)
    assert v.real == pytest.approx(5e-19, rel=1e-9)


@pytest.mark.parametrize("spec,field", [
    (LowPass(kind="low_pass", cutoff_hz=500.0), "velocity_filter.cutoff_hz"),      # at Nyquist
    (LowPass(kind="low_pass", cutoff_hz=700.0, order=2), "velocity_filter.cutoff_hz"),
    (TransferFunctionFilter(kind="transfer_function", numerator=[1000.0, -999.0]), "velocity_filter.numerator"),
    (TransferFunctionFilter(kind="transfer_function", numerator=[2000.0, -2000.0]), "velocity_filter.numerator"),
    (TransferFunctionFilter(kind="transfer_function", numerator=[500.0, -500.0], denominator=[1.0, -1.5]),
     "velocity_filter.denominator"),
    (TransferFunctionFilter(kind="transfer_function", numerator=[0.0, 1000.0, -1000.0], denominator=[1.0, -1.0]),
     "velocity_filter.denominator"),   # a pole on the unit circle
    (TransferFunctionFilter(kind="transfer_function", numerator=[1000.0, -1000.0], denominator=[0.0, 1.0]),
     "velocity_filter.denominator"),
])
def test_refusals_name_their_field(spec, field):
    with pytest.raises(InputError) as exc:
        velocity_transfer(spec, T)
    assert exc.value.field == field


@pytest.mark.parametrize("bad", [
    {"kind": "moving_average", "samples": 0},
    {"kind": "low_pass", "cutoff_hz": float("nan")},
    {"kind": "low_pass", "cutoff_hz": 50.0, "order": 3},
    {"kind": "transfer_function", "numerator": [float("nan"), 1.0]},
    {"kind": "transfer_function", "numerator": [1.0, float("inf")]},
    {"kind": "kalman"},
])
def test_schema_refusals(bad):
    from pydantic import TypeAdapter

    from models.velocity_filter import VelocityFilter
    with pytest.raises(ValidationError):
        TypeAdapter(VelocityFilter).validate_python(bad)


def test_mass_must_be_finite():
    for m in (math.nan, math.inf, 1e13):
        with pytest.raises(InputError) as exc:
            rendering(None, m, T)
        assert exc.value.field == "mass"
    assert rendering(None, 0.0, T) == DEFAULT_RENDERING and DEFAULT_RENDERING.is_default
    # a moving average of one sample is the backward difference: today's wall and its fast path
    assert rendering(MovingAverage(kind="moving_average", samples=1), 0.0, T).is_default
    assert not rendering(MovingAverage(kind="moving_average", samples=2), 0.0, T).is_default
    assert not rendering(None, -0.5, T).is_default


def test_a_cutoff_too_low_to_represent_is_refused():
    for order in (1, 2):
        with pytest.raises(InputError) as exc:
            velocity_transfer(LowPass(kind="low_pass", cutoff_hz=5e-324, order=order), T)
        assert exc.value.field == "velocity_filter.cutoff_hz"


def test_the_stability_kernels_load_without_scipy_signal():
    """scipy.signal (≈ 0.6 s of CPU to import) is imported by the order-2 low pass only: a process that loads the
    analysis (a compute worker, a study's pool worker) does not pay for it (1.8 → 1.2 s of CPU, 2026-12-04)."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    code = ("import sys, optim.stability.analysis, optim.stability.boundary; "
            "print('scipy.signal' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120,
                         cwd=root, env={**os.environ, "PYTHONPATH": str(root)})
    assert out.stdout.strip() == "False", out.stdout + out.stderr
