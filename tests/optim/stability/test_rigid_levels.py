"""The crossover levels of optim.stability.rigid_levels (the compiled loop over the levels, each started from the
spacing of the roots below) against the same levels solved one by one from the middle of their bracket (fast_rigid's
bracketed Newton and secant polish, the exact rung's list before issue 20), and against the scan.  The compiled loop
is held to its Python twin bit for bit in test_rigid_kernel.py.

Random rigid devices with ≥ 40 levels (whole and fractional delays 60-250 samples, δ from 1e-9 to 3), B = 0,
B uniform below B_max and within 1e-3 of it.  Tolerances: θ to 4 ulp (both solve F̃ = 2πk to 2 ulp and
polish on Im H); K to 1e-12 relative, the conditioning of K at the last levels below θ_r (K rises ~250-fold per
rad there, so an ulp of θ moves K by ~5e-14).
"""

import math

import numpy as np
import pytest

from models.device import Device
from optim.stability.fast_rigid import bracketed_newton, fast_rigid, rigid_loop
from optim.stability.margins import critical_stiffness, loop_plant, max_stable_damping, scan_critical_stiffness
from optim.stability.rigid_levels import rigid_crossovers

from .rigid_python import k_equation, polish_h

_EPS = np.finfo(float).eps


def _case(rng, i):
    delta, m, t = 10 ** rng.uniform(-9, 0.5), 10 ** rng.uniform(-3, 1), float(rng.choice([5e-4, 1e-3, 2e-3]))
    ds = float(rng.integers(60, 251)) if i % 2 else float(rng.uniform(60, 250))
    dev = Device(mass=m, damping=delta * m / t, sample_time=t, delay=ds * t)
    kind = i % 3
    b = 0.0 if kind == 0 else max_stable_damping(dev) * (rng.uniform(0, 1) if kind == 1 else 1 - 10 ** rng.uniform(-6, -3))
    return dev, b


def _both(dev, b):
    """(the list of rigid_crossovers, the list with every level alone from its bracket's middle) of one device."""
    plant, beta = loop_plant(dev), b / dev.damping_scale
    res = fast_rigid(plant, beta)
    assert res is not None and res.theta is not None
    first = (res.theta, res.alpha)
    L = rigid_loop(plant)
    got = rigid_crossovers(plant, beta, first, lambda lo: [])
    # every level alone: fast_rigid's scalar solve from θ₀ upwards, as before issue 20
    alone = [first]
    top = (L.half_pis_at_pi - 1) * 0.5 * math.pi if L.theta_r == math.pi else k_equation(L, beta, L.theta_r)[0]
    k = 1
    while 2.0 * math.pi * k < top:
        lo = alone[-1][0]
        t = bracketed_newton(lambda x: k_equation(L, beta, x), 2.0 * math.pi * k, lo, L.theta_r, 0.5 * (lo + L.theta_r))
        t, h = polish_h(plant, beta, t)
        alone.append((t, h.real))
        k += 1
    return got, sorted(c for c in alone if c[1] > 0.0), k - 1


def test_levels_equal_levels_alone_on_random_long_delays():
    rng = np.random.default_rng(20)
    levels = []
    for i in range(240):
        dev, b = _case(rng, i)
        got, alone, n = _both(dev, b)
        levels.append(n)
        assert len(got) == len(alone), (dev, b)
        for (t1, a1), (t2, a2) in zip(got, alone):
            assert abs(t1 - t2) <= 4 * _EPS * t2, (dev, b, t1, t2)
            assert a1 == pytest.approx(a2, rel=1e-12), (dev, b, t1)
    assert sum(n >= 48 for n in levels) >= 120   # long lists: most devices have ≥ 48 levels


def test_levels_equal_the_scan():
    rng = np.random.default_rng(21)
    for i in range(12):
        dev, b = _case(rng, i)
        got, ref = critical_stiffness(dev, b).crossovers, scan_critical_stiffness(dev, b).crossovers
        # near B_max K is a small difference of O(β) terms: an ulp of β or θ moves it by ~ε·B/(B_max − B)
        # (tests/optim/stability/test_fast_rigid.py, the same widening)
        tol = 1e-12 + 4 * _EPS * (b / (max_stable_damping(dev) - b) if b > 0 else 0.0)
        assert len(got) == len(ref), (dev, b)
        for a, c in zip(got, ref):
            assert a.frequency == pytest.approx(c.frequency, rel=1e-9)
            assert a.stiffness == pytest.approx(c.stiffness, rel=tol)
