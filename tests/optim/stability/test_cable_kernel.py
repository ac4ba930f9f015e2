"""optim.stability.cable_kernel (numba) against its Python twin, optim.stability.cable_brackets' cable_min_crossing (the
oracle, its memo cleared), bit for bit: the binding crossover's θ and α, "no crossover", "not resolved" and the pieces
examined.

Random damped cables (tests/optim/stability/random_cables.py: δ 1e-10–1, modes 10 rad/s–0.9·Nyquist, cable damping
1e-9–10× critical, whole and fractional delays up to 200 samples, every fifth under 4), each at B = 0, on the
damper-only loop, at B uniform below β_max and within 1e-4 of it; and the LHifAM cable.  A slow run holds 2,000 more.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from models.device import Device
from optim.stability.cable_brackets import cable_min_crossing, clear_memo
from optim.stability.cable_kernel import cable_min_crossing_compiled
from optim.stability.cable_loop import cable_loop
from optim.stability.margins import _theta_min, loop_plant
from tests.optim.stability.random_cables import random_cable


def _compare(devices: list[Device], seed: int) -> int:
    rng = np.random.default_rng(seed)
    compared = 0
    for dev in devices:
        loop = cable_loop(loop_plant(dev))
        if loop is None:
            continue
        clear_memo()
        damper = cable_min_crossing(loop, 0.0, _theta_min(dev, 0.0), damper=True)
        calls = [(0.0, False), (0.0, True)]
        if damper is not None and damper[0] is not None:
            bm = damper[0][1]
            calls += [(float(rng.uniform(0, 1)) * bm, False), ((1.0 - 10 ** float(rng.uniform(-4, -1))) * bm, False)]
        for beta, is_damper in calls:
            lo = _theta_min(dev, beta)
            clear_memo()
            want = cable_min_crossing(loop, beta, lo, is_damper)
            got = cable_min_crossing_compiled(loop, beta, lo, is_damper)
            assert got == want, (dev, beta, is_damper, got, want)
            compared += 1
    return compared


def _devices(n: int, seed: int) -> list[Device]:
    rng = np.random.default_rng(seed)
    return [random_cable(rng, i, low=0, top=200, short_top=4) for i in range(n)]


def test_kernel_matches_its_python_twin_bit_for_bit():
    lhifam = [Device(preset="lhifam", delay=d) for d in (0.0, 0.0037, 0.005, 0.05, 0.2)]
    assert _compare(lhifam + _devices(40, 3), 4) >= 130


@pytest.mark.slow
def test_kernel_matches_its_python_twin_on_2000_cables():
    assert _compare(_devices(2000, 11), 12) >= 6000


def test_kernel_agrees_with_the_lhifam_answers():
    """The compiled answer is the one margins gives (its path "fast"), finite and at a positive angle."""
    from optim.stability.margins import critical_stiffness

    dev = Device(preset="lhifam", delay=0.005)
    loop = cable_loop(loop_plant(dev))
    got = cable_min_crossing_compiled(loop, 0.0, _theta_min(dev, 0.0))
    assert got is not None and got[0] is not None
    theta, alpha = got[0]
    res = critical_stiffness(dev)
    assert res.path == "fast"
    assert res.critical_stiffness == alpha * dev.stiffness_scale
    assert 0.0 < theta < math.pi
