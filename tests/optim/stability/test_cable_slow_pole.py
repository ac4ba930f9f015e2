"""Cables whose real slow pole 1 − δ' lies within cable_loop.MIN_MODE_GAP (1e-8) of the unit circle (δ < 1e-8: almost
no absolute damping) take the cable brackets (issue 32: they were a fifth of the random cables' fallbacks to the
bounded scan), held to the scan of every crossover exactly as test_cable_brackets holds the others (B_max and K_cr at
B = 0, below B_max and within 1e-4 of it, to 1e-12 widened by their own conditioning).  Their resonances stay
above MIN_MODE_GAP here (those near the circle: test_cable_near_circle.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from models.device import Device
from optim.stability import margins
from optim.stability.cable_loop import cable_loop
from optim.stability.margins import loop_plant
from tests.optim.stability.test_cable_brackets import _check


@pytest.fixture(autouse=True)
def _double_paths_only(monkeypatch):
    monkeypatch.setattr(margins, "RHO_REFINE", math.inf)


def _slow_pole_cables(n: int, seed: int, top: int = 20) -> list[Device]:
    """Random cables (test_cable_brackets' distribution) with δ 1e-12–1e-8 and cable damping 1e-6–10× critical."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(n):
        t = float(rng.choice([5e-4, 1e-3, 2e-3]))
        m = 10 ** rng.uniform(-3, 1)
        delta = 10 ** rng.uniform(-12, -8)
        ds = float(rng.integers(0, top + 1)) if i % 2 else float(rng.uniform(0, top))
        mr = m * rng.uniform(0.05, 0.9)
        md = m - mr
        wn = min(10 ** rng.uniform(1, 4), 0.9 * math.pi / t)
        kc = wn ** 2 * mr * md / m
        b = delta * m / t
        br = b * rng.uniform(0, 1)
        bc = 2.0 * math.sqrt(kc * mr * md / m) * 10 ** rng.uniform(-6, 1)
        out.append(Device(cable=dict(motor_mass=mr, body_mass=md, motor_damping=br, body_damping=b - br,
                                     stiffness=kc, damping=bc), sample_time=t, delay=ds * t))
    return out


def test_slow_pole_cables_take_the_brackets_and_agree_with_the_scan():
    devs = _slow_pole_cables(12, 21)
    assert sum(cable_loop(loop_plant(d)) is not None for d in devs) >= 10
    fast, n = _check(devs, 21)
    assert fast >= 0.75 * n


@pytest.mark.slow
def test_slow_pole_cables_agree_with_the_scan_on_600_devices():
    fast, n = _check(_slow_pole_cables(500, 22) + _slow_pole_cables(100, 23, top=200), 22)
    assert fast >= 0.9 * n
