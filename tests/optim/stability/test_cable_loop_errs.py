"""cable_loop.root_errors (the roots' error bounds in Python numbers, issue 32) against numpy.polynomial's expression
it replaced, bit for bit: every bound the cable brackets allow for is the number it was."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.polynomial import polynomial as P

from models.device import Device
from optim.stability.cable_loop import _EPS, _numerator_w, root_errors
from optim.stability.margins import loop_plant


def _numpy_errors(coef: np.ndarray) -> list[float]:
    """The expression cable_loop._build used before root_errors (numpy.polynomial's polyval and polyder)."""
    wz = P.polyroots(coef)
    dcoef = P.polyder(coef)
    return [float(64.0 * _EPS * P.polyval(abs(v), np.abs(coef)) / max(abs(P.polyval(v, dcoef)), 1e-300))
            for v in wz]


def _same(coef: np.ndarray) -> None:
    ref = _numpy_errors(coef)
    got = root_errors(coef.tolist(), [complex(v) for v in P.polyroots(coef)])
    assert [x.hex() for x in got] == [x.hex() for x in ref]


@pytest.mark.parametrize("seed", range(3))
def test_random_polynomials(seed):
    rng = np.random.default_rng(seed)
    for _ in range(400):
        deg = int(rng.integers(2, 7))
        coef = rng.normal(size=deg + 1) * 10.0 ** rng.uniform(-12, 12, deg + 1)
        coef[rng.random(deg + 1) < 0.1] *= -1e-9            # some tiny coefficients, mixed signs
        _same(coef)


def test_cable_numerators():
    """The numerators _build factors: random cables at whole and fractional delays (their modal forms)."""
    rng = np.random.default_rng(7)
    base = Device(preset="lhifam")
    n = 0
    for _ in range(120):
        cable = base.cable.model_copy(update={"stiffness": float(rng.uniform(2e3, 3e5)),
                                              "damping": float(rng.uniform(0.0, 40.0)),
                                              "motor_damping": float(rng.choice([0.0, 0.1, 3.0]))})
        dev = base.model_copy(update={"cable": cable, "delay": float(rng.choice([0.0, 0.0025, 0.0137]))})
        plant = loop_plant(dev)
        modal = plant.modal_form()
        if modal is None:
            continue
        coef = _numerator_w(modal, plant.f > 0.0)
        while coef.size > 1 and coef[-1] == 0.0:
            coef = coef[:-1]
        if coef.size >= 2 and np.all(np.isfinite(coef)):
            _same(coef)
            n += 1
    assert n > 100
