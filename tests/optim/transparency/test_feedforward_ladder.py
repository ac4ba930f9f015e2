"""The force-feedforward loop on every rung of the ladder, against the independent 40-digit reference."""

from __future__ import annotations

import math

import numpy as np
import pytest

from models.device import Device
from models.feedforward import feedforward_plant
from models.filters import ButterworthLowPass
from optim.transparency.feedforward import critical_force_gain
from optim.transparency.feedforward_ladder import analyse_force_feedforward
from optim.transparency.feedforward_reference import (
    REFERENCE_FORCE_GAIN_MAX_DELAY_SAMPLES,
    reference_critical_force_gain,
    reference_g1,
)
from tests.feedforward_reference import (
    EQ32_CRITICAL_FORCE_GAIN,
    EQ32_RTOL,
    EQ33_WORST_CASE,
    HUMAN_EQ30,
    LHIFAM_CABLE,
    LHIFAM_RIGID,
    SENSOR_EQ31,
)


def _dev(params: dict, delay: float = 0.0, **kw) -> Device:
    return Device(**params, delay=delay, human=HUMAN_EQ30, force_sensor=kw.get("sensor", SENSOR_EQ31))


F30 = ButterworthLowPass(2, 30.0, 1e-3)      # the chapter's §5.2 filter
CASES = [
    (_dev(LHIFAM_RIGID), None),
    (_dev(LHIFAM_RIGID, 0.00237), F30),
    (_dev(LHIFAM_CABLE, 0.001), None),
    (_dev(LHIFAM_CABLE, 0.005), F30),
    (_dev(LHIFAM_RIGID, 0.0013, sensor=None), ButterworthLowPass(3, 45.0, 1e-3)),   # direct term, 3rd order
]


def test_reference_reproduces_eq32():
    r = reference_critical_force_gain(CASES[0][0], CASES[0][0].human)
    assert r.critical_force_gain == pytest.approx(EQ32_CRITICAL_FORCE_GAIN, rel=EQ32_RTOL)
    assert r.crossover_frequency == pytest.approx(math.pi / 1e-3, rel=1e-15)


@pytest.mark.slow
@pytest.mark.parametrize("dev, filt", CASES)
def test_exact_agrees_with_reference(dev, filt):
    """Two implementations sharing no numerical code: 1e-9 is the contract (measured ~1e-15)."""
    ref = analyse_force_feedforward(dev, filt, method="reference")
    ex = analyse_force_feedforward(dev, filt, method="exact")
    assert ex.critical_force_gain == pytest.approx(ref.critical_force_gain, rel=1e-9)
    assert ex.crossover_frequency == pytest.approx(ref.crossover_frequency, rel=1e-9)
    assert ref.method == "reference" and ref.error_estimate < 1e-30 and ex.error_estimate <= 1e-12


@pytest.mark.parametrize("dev, filt", CASES)
def test_linear_is_eq33_and_its_estimate_is_honest(dev, filt):
    lin = analyse_force_feedforward(dev, filt, method="linear")
    assert lin.critical_force_gain == pytest.approx(1 + dev.mass / dev.human.mass, rel=1e-15)
    truth = critical_force_gain(dev, filt).critical_force_gain
    err = abs(lin.critical_force_gain / truth - 1)
    assert err <= 2 * lin.error_estimate, (err, lin.error_estimate)
    assert lin.crossover_frequency is None and "eq. 33" in lin.error_source


def test_linear_estimate_small_in_the_large_delay_limit():
    """Eq. 33 is the large-delay limit: at 0.1 s the rung must say it is good (a few %), and be."""
    dev = _dev(LHIFAM_RIGID, 0.1)
    lin = analyse_force_feedforward(dev, None, method="linear")
    assert lin.critical_force_gain == pytest.approx(EQ33_WORST_CASE, rel=1e-12)
    assert lin.error_estimate < 0.1
    truth = critical_force_gain(dev).critical_force_gain
    assert abs(lin.critical_force_gain / truth - 1) <= 2 * lin.error_estimate


@pytest.mark.parametrize("dev, filt", CASES[:4])
def test_grid_converges_to_exact(dev, filt):
    exact = critical_force_gain(dev, filt).critical_force_gain
    coarse = analyse_force_feedforward(dev, filt, method="grid", grid_points=300)
    fine = analyse_force_feedforward(dev, filt, method="grid", grid_points=30000)
    e_fine = abs(fine.critical_force_gain / exact - 1)
    assert e_fine <= max(abs(coarse.critical_force_gain / exact - 1), 1e-12)
    assert e_fine < 1e-3  # linear interpolation on 30000 log points
    assert fine.method == "grid" and "30000" in fine.error_source


def test_reference_g1_matches_the_exact_discretisation():
    dev = _dev(LHIFAM_CABLE, 0.00137)
    plant = feedforward_plant(dev, dev.human)
    for th in (1e-3, 0.3, 1.7, math.pi):
        ref = reference_g1(dev, dev.human, th)
        assert abs(plant.response(np.array([th]))[0] - ref) <= 1e-9 * abs(ref)


def test_bad_rungs_and_caps_raise_naming_the_field():
    dev = CASES[0][0]
    with pytest.raises(ValueError, match="^method"):
        analyse_force_feedforward(dev, method="bisect")
    with pytest.raises(ValueError, match="^grid_points"):
        analyse_force_feedforward(dev, method="grid", grid_points=5)
    far = _dev(LHIFAM_RIGID, (REFERENCE_FORCE_GAIN_MAX_DELAY_SAMPLES + 1) * 1e-3)
    with pytest.raises(ValueError, match="^device.delay"):
        analyse_force_feedforward(far, method="reference")


@pytest.mark.parametrize("dev, filt", CASES + [(_dev(LHIFAM_CABLE, 0.05), F30), (_dev(LHIFAM_CABLE, 0.05), None)])
def test_grid_error_estimate_is_honest(dev, filt):
    """The grid rung's true error (against the exact rung, held to the 40-digit reference elsewhere) ≤ 2 × its
    estimate; the cable, 30 Hz, 50-sample case is the one where half the bracket's change understated it 2.7×."""
    exact = critical_force_gain(dev, filt).critical_force_gain
    grid = analyse_force_feedforward(dev, filt, method="grid")
    assert abs(grid.critical_force_gain / exact - 1) <= 2 * grid.error_estimate
