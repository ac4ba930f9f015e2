"""``passivity_margin`` (grid + vectorised Newton on P') against the bounded Brent searches it replaced.

The reference below is the previous implementation, kept here verbatim as the second computation: three
``scipy.optimize.minimize_scalar`` bounded searches around the grid's three largest samples.  Both must give
the same sup P(θ) to 1e-12 (relative to the scale (K·T/2)(2d+1) + B of P, since P itself may cancel to 0) plus
the answer's own error bound (it is a proven upper bound since issue 34: never below the sup, at most
``error_bound`` above it), and the same verdict wherever the margin b − sup P is outside that band.
"""

import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from models.device import Device
from optim.stability.passivity import _grid, kernel, passivity_margin, passivity_samples


def _refine_min(fun, grid, values, idx):
    lo, hi = grid[max(idx - 1, 0)], grid[min(idx + 1, grid.size - 1)]
    best_t, best_v = float(grid[idx]), float(values[idx])
    if hi > lo:
        res = minimize_scalar(lambda t: float(fun(np.array([t]))[0]), bounds=(lo, hi), method="bounded",
                              options={"xatol": 1e-14})
        if res.fun < best_v:
            best_t, best_v = float(res.x), float(res.fun)
    return best_t, best_v


def brent_required_damping(device: Device, stiffness: float, damping: float) -> tuple[float, float]:
    """(sup P, worst θ): the pre-issue-20 ``passivity_margin``."""
    d, _ = passivity_samples(device)
    half_t = device.sample_time / 2

    def minus_p(theta):
        s, c = kernel(theta, d)
        return -(stiffness * half_t * s - damping * c)

    grid = _grid(d)
    vals = minus_p(grid)
    order = np.argsort(vals)[:3]
    t_best, v_best = min((_refine_min(minus_p, grid, vals, int(i)) for i in order), key=lambda tv: tv[1])
    return -v_best, t_best


def _random_cases(n: int, seed: int):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        t = float(10 ** rng.uniform(-4.5, -2))
        d_max = 40 if rng.random() < 0.8 else 400
        delay = float(rng.uniform(0, d_max)) * t
        if rng.random() < 0.4:
            delay = round(delay / t) * t          # whole samples
        dev = Device(mass=float(10 ** rng.uniform(-3.5, 1.5)), damping=float(10 ** rng.uniform(-3, 1.5)),
                     sample_time=t, delay=delay)
        k = float(10 ** rng.uniform(0, 6))
        b = 0.0 if rng.random() < 0.3 else float(10 ** rng.uniform(-3, 2)) * (k * t)
        yield dev, k, b


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1])
def test_fast_margin_equals_the_brent_searches_on_random_devices(seed):
    worst = 0.0
    for dev, k, b in _random_cases(250, seed):
        new = passivity_margin(dev, k, b)
        ref, _ = brent_required_damping(dev, k, b)
        d = new.delay_samples_used
        scale = k * dev.sample_time / 2 * (2 * d + 1) + b
        err = (new.required_damping - new.error_bound - ref) / scale
        worst = max(worst, abs(err))
        assert abs(err) <= 1e-12, (dev, k, b, new.required_damping, ref)
        # never below the old answer by more than rounding: the bound lies above every value
        assert new.required_damping >= ref - 1e-13 * scale
        if abs(dev.damping - ref) > 1e-12 * scale + new.error_bound:
            assert new.passive == (dev.damping > ref)
        # the worst angle is where P takes the largest value met, at most error_bound below the answer
        s, c = kernel(np.array([new.worst_angle]), d)
        at = k * dev.sample_time / 2 * s[0] - b * c[0]
        assert -1e-13 * scale <= new.required_damping - at <= new.error_bound + 1e-13 * scale
    assert worst <= 1e-12


@pytest.mark.parametrize("d", [0, 1, 2, 7, 30])
def test_fast_margin_closed_forms(d):
    """B = 0: sup P = (K·T/2)(2d+1) at θ → 0; d = 0: eq. 3, K·T/2 + B (at θ = π)."""
    t = 1e-3
    dev = Device(mass=1.0, damping=1.0, sample_time=t, delay=d * t)
    k = 2000.0
    assert passivity_margin(dev, k, 0.0).required_damping == pytest.approx(k * t / 2 * (2 * d + 1), rel=1e-14)
    if d == 0:
        assert passivity_margin(dev, k, 3.0).required_damping == pytest.approx(k * t / 2 + 3.0, rel=1e-14)
        assert passivity_margin(dev, k, 3.0).worst_angle == pytest.approx(math.pi, rel=1e-12)
