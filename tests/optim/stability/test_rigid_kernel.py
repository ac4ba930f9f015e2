"""optim.stability.rigid_kernel (numba) against its Python twins (tests/optim/stability/rigid_python.py: the exact
rung as it ran in Python), bit for bit: the scalar evaluators (``_k_eq``/``_psi``, ``_h``, Re H), the binding
crossover (bracketed_newton from fast_rigid's closed-form start, polish_h) and the levels' loop.

Random rigid devices over the documented domain: δ from 1e-30 to 1e3 (a twentieth of them δ = 0 with B > 0),
whole and fractional delays of 0-400 samples, B = 0, B uniform below B_max and within 1e-6…1e-3 of it; T of
0.1-2 ms and masses 1e-4-100 kg (the dimensionless loop is what the kernel sees).
"""

import math

import numpy as np
import pytest

from models.device import Device
from optim.stability import fast_rigid as fr
from optim.stability import rigid_kernel as rk
from optim.stability.margins import loop_plant, max_stable_damping
from optim.stability.rigid_levels import level_count

from . import rigid_python as rp
from .rigid_python import level_roots as python_level_roots

_HALF_PI = 0.5 * math.pi
_TWO_PI = 2.0 * math.pi


def _device(rng, i):
    m, t = 10 ** rng.uniform(-4, 2), float(rng.choice([1e-4, 5e-4, 1e-3, 2e-3]))
    delta = 0.0 if i % 20 == 7 else 10 ** rng.uniform(-30, 3)
    ds = float(rng.integers(0, 401)) if i % 2 else float(rng.uniform(0, 400))
    return Device(mass=m, damping=delta * m / t, sample_time=t, delay=ds * t)


def _beta(rng, i, dev):
    kind = i % 3 if dev.damping > 0 else 1 + i % 2
    if kind == 0:
        return 0.0
    try:
        b_max = max_stable_damping(dev)
    except ValueError:
        return None
    if not (math.isfinite(b_max) and b_max > 0):
        return None
    frac = rng.uniform(0, 1) if kind == 1 else 1 - 10 ** rng.uniform(-6, -3)
    return b_max * frac / dev.damping_scale


def _levels(L, beta, t0):
    """The level count of rigid_levels.rigid_crossovers (none when the binding crossover is not below θ_r)."""
    return level_count(L, beta) if t0 < L.theta_r else 0


def _python_binding(plant, L, beta, hi):
    """fast_rigid's binding crossover as it ran in Python."""
    fun = (lambda x: rp._psi(L, x)) if beta == 0.0 else (lambda x: rp._k_eq(L, beta, x))
    t = rp.bracketed_newton(fun, 0.0, 0.0, hi, fr._start(L, L.omp + beta, _HALF_PI, hi))
    t, h = rp.polish_h(plant, beta, t)
    return t, h.real


def _same(a, b) -> bool:
    return a == b or (isinstance(a, float) and math.isnan(a) and math.isnan(b))


def test_kernel_equals_its_python_twins_bit_for_bit():
    rng = np.random.default_rng(2024)
    devices = levels = bindings = evaluations = 0
    for i in range(1500):
        dev = _device(rng, i)
        plant = loop_plant(dev)
        L = fr.rigid_loop(plant)
        if L is None:
            continue
        beta = _beta(rng, i, dev)
        if beta is None:
            continue
        v = L.numbers
        for t in [*np.concatenate([rng.uniform(1e-7, math.pi, 3), 10 ** rng.uniform(-12, 0, 2)]).tolist(), math.pi]:
            for b in (beta, 0.0):
                assert all(map(_same, rk.k_eq(v, b, t), rp._k_eq(L, b, t))), (dev, b, t)
                assert rk._h(v, b, t) == rp._h(plant, b, t), (dev, b, t)
                assert _same(rk.re_h(v, b, t), rp.re_h(plant, b, t)), (dev, b, t)
                evaluations += 2
        res = fr.fast_rigid(plant, beta)
        if res is None or res.theta is None:
            continue
        hi = L.theta_r if beta == 0.0 else min(fr._damper_root(L)[0], L.theta_r)
        if not (hi == math.pi and L.half_pis_at_pi == 1):   # else the Nyquist point, no solve
            assert (res.theta, res.alpha) == _python_binding(plant, L, beta, hi), (dev, beta)
            bindings += 1
        n = _levels(L, beta, res.theta)
        if n == 0:
            continue
        theta, alpha = rk.level_roots(v, beta, n, res.theta, L.theta_r)
        assert list(zip(theta.tolist(), alpha.tolist())) == python_level_roots(
            plant, L, beta, n, res.theta, L.theta_r), (dev, beta, n)
        devices += 1
        levels += n
    # the domain was covered: long lists, both delay kinds, B = 0 and B > 0
    assert devices >= 900 and levels >= 50_000 and bindings >= 1200 and evaluations >= 20_000


@pytest.mark.parametrize("delay_samples", [0, 3, 2.5, 50, 199.25])
def test_compile_kernels_leaves_answers_alone(delay_samples):
    """compile_kernels runs the kernels on a made-up loop: the next answer on a real one is unchanged."""
    dev = Device(mass=1.05e-3, damping=0.0085, sample_time=1e-3, delay=delay_samples * 1e-3)
    plant, L = loop_plant(dev), fr.rigid_loop(loop_plant(dev))
    before = fr.fast_rigid(plant, 1e-3)
    rk.compile_kernels()
    assert fr.fast_rigid(plant, 1e-3) == before
    assert L.numbers[-1] == (0.0 if float(delay_samples).is_integer() else 1.0)


def test_kernel_equals_its_python_twin_up_to_the_delay_limit():
    """Delays of 2,000 to MAX_DELAY_SAMPLES (10,000): lists of thousands of levels, bit for bit."""
    from models.device import MAX_DELAY_SAMPLES

    rng = np.random.default_rng(4048)
    longest = 0
    for i in range(24):
        ds = float(rng.uniform(2000, MAX_DELAY_SAMPLES)) if i % 2 else float(MAX_DELAY_SAMPLES - rng.integers(0, 8000))
        m, t = 10 ** rng.uniform(-3, 1), 1e-3
        dev = Device(mass=m, damping=10 ** rng.uniform(-12, 1) * m / t, sample_time=t, delay=ds * t)
        plant = loop_plant(dev)
        L = fr.rigid_loop(plant)
        beta = _beta(rng, i, dev)
        if L is None or beta is None:
            continue
        res = fr.fast_rigid(plant, beta)
        if res is None or res.theta is None:
            continue
        n = _levels(L, beta, res.theta)
        theta, alpha = rk.level_roots(L.numbers, beta, n, res.theta, L.theta_r)
        assert list(zip(theta.tolist(), alpha.tolist())) == python_level_roots(
            plant, L, beta, n, res.theta, L.theta_r), (dev, beta, n)
        longest = max(longest, n)
    assert longest >= 2000


def test_compiled_tail_proof_gives_rigid_tails_verdicts():
    """optim.stability.rigid_tail.tail_is_clear (compiled) against its Python twin, on random devices with the rising
    range ending before π (zeros near −1, whole and fractional delays)."""
    from optim.stability.rigid_tail import tail_is_clear

    from .rigid_python import tail_is_clear as python_tail_is_clear

    rng = np.random.default_rng(909)
    verdicts = {True: 0, False: 0}
    for i in range(3000):
        dev = _device(rng, i)
        if i % 4 == 0:   # short delays: the tail check's own ground (θ_r < π more often)
            dev = Device(mass=dev.mass, damping=dev.damping, sample_time=dev.sample_time,
                         delay=float(rng.uniform(0, 30)) * dev.sample_time)
        L = fr.rigid_loop(loop_plant(dev))
        beta = _beta(rng, i, dev)
        if L is None or beta is None:
            continue
        want = python_tail_is_clear(L, beta)
        assert tail_is_clear(L, beta) == want, (dev, beta)
        if L.theta_r < math.pi:
            verdicts[want] += 1
    assert verdicts[True] >= 300 and verdicts[False] >= 10, verdicts
