"""The crossover levels solved together (optim.stability.rigid_levels) against the same levels solved one by one
(fast_rigid's bracketed Newton and secant polish, the exact rung's list before issue 20's vectorisation), the scan,
and the scalar evaluators it mirrors bit for bit.

Random rigid devices with ≥ 40 levels (whole and fractional delays 60-250 samples, δ from 1e-9 to 3), B = 0,
B uniform below B_max and within 1e-3 of it.  Tolerances: θ to 4 ulp (both solve F̃ = 2πk to 2 ulp and
polish on Im H); K to 1e-12 relative, the conditioning of K at the last levels below θ_r (K rises ~250-fold per
rad there, so an ulp of θ moves K by ~5e-14).
"""

import math

import numpy as np
import pytest

from models.device import Device
from optim.stability.fast_rigid import bracketed_newton, fast_rigid, k_equation, polish_h, re_h, rigid_loop
from optim.stability.margins import critical_stiffness, loop_plant, max_stable_damping, scan_critical_stiffness
from optim.stability.rigid_levels import h_array, polish_array, rigid_crossovers

_EPS = np.finfo(float).eps


def _case(rng, i):
    delta, m, t = 10 ** rng.uniform(-9, 0.5), 10 ** rng.uniform(-3, 1), float(rng.choice([5e-4, 1e-3, 2e-3]))
    ds = float(rng.integers(60, 251)) if i % 2 else float(rng.uniform(60, 250))
    dev = Device(mass=m, damping=delta * m / t, sample_time=t, delay=ds * t)
    kind = i % 3
    b = 0.0 if kind == 0 else max_stable_damping(dev) * (rng.uniform(0, 1) if kind == 1 else 1 - 10 ** rng.uniform(-6, -3))
    return dev, b


def _both(dev, b):
    """(the list with the levels together, the list with every level alone) of the same device."""
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


def test_levels_together_equal_levels_alone_on_random_long_delays():
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
    assert sum(n >= 48 for n in levels) >= 120   # most took the numpy passes (fewer levels: the loop)


def test_levels_together_equal_the_scan():
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


@pytest.mark.parametrize("delay", [0.05, 0.0374])
def test_array_evaluators_are_the_scalar_ones_bit_for_bit(delay):
    """h_array and polish_array (CPython's complex arithmetic written out on arrays) against fast_rigid.polish_h at
    random θ, whole (one zero) and fractional (two zeros) delays, B = 0 and B > 0: the same bits."""
    rng = np.random.default_rng(3)
    for _ in range(20):
        m = 10 ** rng.uniform(-3, 1)
        dev = Device(mass=m, damping=10 ** rng.uniform(-9, 0.5) * m / 1e-3, sample_time=1e-3, delay=delay)
        plant = loop_plant(dev)
        for beta in (0.0, float(rng.uniform(0, 1e-3))):
            t = np.sort(rng.uniform(1e-4, math.pi, 50))
            theta, alpha, _ = polish_array(plant, beta, t)
            re, im = h_array(plant, beta, t)
            for i, ti in enumerate(t.tolist()):
                tp, hp = polish_h(plant, beta, ti)
                assert (theta[i], alpha[i]) == (tp, hp.real)
                assert re[i] == re_h(plant, beta, ti)
                if tp == ti:   # polish_h kept θ: its H is H(θ)
                    assert im[i] == hp.imag
