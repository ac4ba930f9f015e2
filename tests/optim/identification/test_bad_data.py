"""Every bad-data rule answers ValueError("data.<field>: rule"); clipping is a warning; a fit that cannot be
trusted is `failed` with its reason and no device."""

from __future__ import annotations

import numpy as np
import pytest

from optim.identification import FrequencyResponseData, TimeSeriesData, identify
from optim.identification.data import MAX_SAMPLES
from tests.optim.identification.cases import T, noisy_response, record


def _ts(force, position):
    return TimeSeriesData(sample_time=T, force=np.asarray(force, float), position=np.asarray(position, float))


def test_lengths_differ():
    d = record("rigid", 0.001)
    with pytest.raises(ValueError, match=r"^data\.position: must have as many values"):
        identify(_ts(d.force, d.position[:-1]))


@pytest.mark.parametrize("where", ("force", "position"))
def test_non_finite(where):
    d = record("rigid", 0.001)
    bad = getattr(d, where).copy()
    bad[17] = np.nan
    data = _ts(bad, d.position) if where == "force" else _ts(d.force, bad)
    with pytest.raises(ValueError, match=rf"^data\.{where}: every value must be finite \(index 17"):
        identify(data)


def test_non_finite_response():
    d = noisy_response("rigid", 0.001)
    h = d.response.copy()
    h[3] = complex(np.inf, 0)
    with pytest.raises(ValueError, match=r"^data\.real: every value must be finite"):
        identify(FrequencyResponseData(d.frequency, h, T))


def test_too_few_samples():
    d = record("rigid", 0.001)
    with pytest.raises(ValueError, match=r"^data\.force: 30 samples are too few for 4 free parameters"):
        identify(_ts(d.force[:30], d.position[:30]), model="rigid")


def test_too_many_samples():
    with pytest.raises(ValueError, match=rf"^data\.force: at most {MAX_SAMPLES} samples"):
        identify(_ts(np.ones(MAX_SAMPLES + 1), np.ones(MAX_SAMPLES + 1)))


def test_constant_input():
    n = 1000
    with pytest.raises(ValueError, match=r"^data\.force: the input is constant"):
        identify(_ts(np.full(n, 2.0), np.linspace(0, 1, n) ** 2))


def test_single_sine_is_too_narrow_for_rigid():
    """A sine dwell at 40 Hz (the band is measured with a resolution of 1/(1024 T), ~1 Hz at 1 kHz)."""
    n = 4000
    u = np.sin(2 * np.pi * 40 * np.arange(n) * T)
    with pytest.raises(ValueError, match=r"^data\.force: too narrow a band for the rigid model"):
        identify(_ts(u, np.cumsum(np.cumsum(u)) * 1e-7), model="rigid")


def test_narrow_band_for_cable_but_enough_for_rigid():
    """Two low tones identify a rigid device but cannot reveal an 84 Hz mode: `cable` is refused, `auto`
    fits the rigid model only and says why."""
    n = 4000
    t = np.arange(n) * T
    u = np.sin(2 * np.pi * 3 * t) + np.sin(2 * np.pi * 9 * t)
    from tests.optim.identification.cases import device
    from tests.optim.identification.synthetic import simulate_experiment
    y = simulate_experiment(device("rigid", 0.001), u, quantization=5e-6, noise=5e-6)
    with pytest.raises(ValueError, match=r"^data\.force: too narrow a band for the cable model"):
        identify(_ts(u, y), model="cable")
    res = identify(_ts(u, y), model="auto")
    assert res.model == "rigid" and "cable model was not fitted" in res.reason


def test_response_needs_two_points_per_parameter():
    d = noisy_response("rigid", 0.001, points=5)
    with pytest.raises(ValueError, match=r"^data\.frequency: 5 points are too few for 3 free parameters"):
        identify(d, model="rigid")
    d = noisy_response("cable", 0.001, points=13)
    with pytest.raises(ValueError, match=r"^data\.frequency: 13 points are too few for 7 free parameters"):
        identify(d, model="cable")


def test_response_lengths_and_values():
    d = noisy_response("rigid", 0.001)
    with pytest.raises(ValueError, match=r"^data\.real: frequency, real and imag must have the same length"):
        identify(FrequencyResponseData(d.frequency[:-1], d.response, T))
    w = d.frequency.copy()
    w[0] = -1.0
    with pytest.raises(ValueError, match=r"^data\.frequency: every frequency must be > 0"):
        identify(FrequencyResponseData(w, d.response, T))
    with pytest.raises(ValueError, match=r"^data\.frequency: a sampled response is defined below the Nyquist"):
        identify(FrequencyResponseData(d.frequency * 20, d.response, T, model_kind="sampled"))


def test_options():
    d = record("rigid", 0.001)
    with pytest.raises(ValueError, match=r"^known\.stiffness: not a free parameter"):
        identify(d, model="rigid", known={"stiffness": 1.0})
    with pytest.raises(ValueError, match=r"^known\.mass: not a free parameter here \(with model auto"):
        identify(d, model="auto", known={"mass": 1.0})
    with pytest.raises(ValueError, match=r"^known: fixes every parameter of the rigid model"):
        identify(d, model="rigid", known={"mass": 5.4, "damping": 3.5, "delay": 0.001})
    with pytest.raises(ValueError, match=r"^known\.mass: must be finite and > 0"):
        identify(d, model="rigid", known={"mass": 0.0})
    with pytest.raises(ValueError, match=r"^friction: the Coulomb term needs a time series"):
        identify(noisy_response("rigid", 0.001), friction=True)
    with pytest.raises(ValueError, match=r"^max_delay: must be in"):
        identify(d, max_delay=1.0)
    with pytest.raises(ValueError, match=r"^confidence: must be in"):
        identify(d, confidence=1.0)


@pytest.mark.slow
def test_clipped_data_warns():
    d = record("rigid", 0.001)
    u = np.clip(d.force, -2.0, 2.0)               # the chirp + PRBS has many values: a clipped one is visible
    res = identify(_ts(u, d.position), model="rigid")
    assert any(w.startswith("data.force:") and "clipped or saturated" in w for w in res.warnings)
    top = np.quantile(d.position, 0.9)
    res = identify(_ts(d.force, np.minimum(d.position, top)), model="rigid")
    assert any(w.startswith("data.position:") and "at the maximum" in w for w in res.warnings)
    clean = identify(d, model="rigid")
    assert not any("clipped" in w for w in clean.warnings)


@pytest.mark.slow
def test_cable_asked_of_a_rigid_device_is_not_claimed_silently():
    """A rigid device's record asked for the cable model: there is no cable mode to find.  Either the fit fails
    (no device) or the answer says the rigid model explains the data better (BIC)."""
    res = identify(record("rigid", 0.001), model="cable")
    if res.status == "failed":
        assert res.device is None and res.parameters == {} and res.uncertainty == {}
        assert res.reason.startswith("the cable fit failed: ")
    else:
        assert any(w.startswith("model: the rigid model explains these data better") for w in res.warnings)
    assert [c.model for c in res.comparison] == ["rigid", "cable"]


@pytest.mark.slow
def test_unconverged_fit_fails_without_a_device():
    """A response of a rigid device asked for the cable model: least squares wanders along the unidentifiable
    directions and does not converge, so `failed` with the reason (never a made-up device)."""
    res = identify(noisy_response("rigid", 0.0013), model="cable")
    assert res.status == "failed" and res.device is None and res.parameters == {} and res.uncertainty == {}
    assert res.reason.startswith("the cable fit failed: ")


def test_pure_noise_fails_or_says_not_white():
    rng = np.random.default_rng(5)
    u = rng.normal(size=2000)
    res = identify(_ts(u, rng.normal(size=2000) * 1e-3), model="rigid")
    assert res.status == "failed" or any("not white" in w or "edge" in w for w in res.warnings), res
