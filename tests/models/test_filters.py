"""Butterworth D(z), bilinear transform prewarped at the cutoff (chapter §5.2)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from models.filters import ButterworthLowPass, butterworth_response


@pytest.mark.parametrize("order", [1, 2, 3, 4])
@pytest.mark.parametrize("cutoff_hz", [10.0, 30.0, 82.0, 400.0])
def test_prewarp_puts_minus_3db_exactly_at_the_cutoff(order, cutoff_hz):
    f = ButterworthLowPass(order, cutoff_hz, 1e-3)
    z, p, k = f.zpk()
    _, h = signal.freqz_zpk(z, p, k, worN=[f.cutoff_angle])
    # scipy's design (butter with fs) and our closed form both: 1/√2 to rounding
    assert abs(h[0]) == pytest.approx(1 / math.sqrt(2), rel=1e-12)
    assert abs(f.response(f.cutoff_angle)[0]) == pytest.approx(1 / math.sqrt(2), rel=1e-14)


@pytest.mark.parametrize("order", [1, 2, 3, 4])
def test_closed_form_equals_scipy_bilinear_design(order):
    """Our D(e^{jθ}) = 1/P_n(j tan(θ/2)/tan(θ_c/2)) against scipy.signal.butter(analog) + bilinear with prewarp."""
    fs, fc = 1000.0, 30.0
    wa = 2 * fs * math.tan(math.pi * fc / fs)                     # prewarped analog cutoff [rad/s]
    b, a = signal.butter(order, wa, analog=True)
    bz, az = signal.bilinear(b, a, fs)
    theta = np.linspace(1e-3, math.pi - 1e-3, 400)
    _, ref = signal.freqz(bz, az, worN=theta)
    ours = ButterworthLowPass(order, fc, 1 / fs).response(theta)
    assert np.max(np.abs(ours - ref)) <= 1e-9  # tf-form rounding of scipy's bilinear at order 4
    assert ButterworthLowPass(order, fc, 1 / fs).response(math.pi)[0] == 0.0


def test_unit_dc_gain_and_monotone_magnitude():
    theta = np.linspace(0.0, math.pi, 2001)
    mag = np.abs(butterworth_response(theta, 0.2, 3))
    assert mag[0] == pytest.approx(1.0, abs=1e-15)
    assert np.all(np.diff(mag) <= 1e-15)


@pytest.mark.parametrize("order, cutoff, msg", [(0, 30.0, "order"), (5, 30.0, "order"),
                                                (2, 0.0, "cutoff_hz"), (2, 500.0, "cutoff_hz"),
                                                (2, float("nan"), "cutoff_hz")])
def test_rejects_bad_parameters(order, cutoff, msg):
    with pytest.raises(ValueError, match=msg):
        ButterworthLowPass(order, cutoff, 1e-3)
