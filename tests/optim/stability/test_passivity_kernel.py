"""optim.stability.passivity_kernel (numba) against its Python twins, bit for bit: the samples of P
(tests/optim/stability/passivity_python.py, passivity_margin's numpy sampling as it ran) and the polish of P's
maximum (passivity._polish_max), then passivity_margin whole against itself with the twins put back.

Random walls: delays of 1-400 samples (whole and fractional: the passivity test rounds up), B from 1e-3 to 100×
the physical damping, K from 1e-2 to 10× the no-delay passivity bound b/(T/2 + t_d), T 0.1-2 ms, m 1e-4-100 kg.
"""

import math

import numpy as np
import pytest

from models.device import Device
from optim.stability import passivity
from optim.stability import passivity_kernel as pk

from . import passivity_python as twin
from .passivity_python import _passivity_prefix

pytestmark = pytest.mark.skipif(
    bool(np.sin(np.array([1.2345678e3]))[0] != math.sin(1.2345678e3)),
    reason="numpy's sin is not libm's on this machine: the numpy twin cannot match the compiled loop bit for bit")


def _wall(rng, i):
    m, t, b = 10 ** rng.uniform(-4, 2), float(rng.choice([1e-4, 5e-4, 1e-3, 2e-3])), 10 ** rng.uniform(-3, 2)
    ds = float(rng.integers(1, 401)) if i % 2 else float(rng.uniform(0.01, 400))
    dev = Device(mass=m, damping=b, sample_time=t, delay=ds * t)
    k = b / (t / 2 + ds * t) * 10 ** rng.uniform(-2, 1)
    return dev, k, b * 10 ** rng.uniform(-3, 2)


def _same_array(a, b) -> bool:
    return a.shape == b.shape and bool(np.all((a == b) | (np.isnan(a) & np.isnan(b))))


def test_prefix_and_polish_equal_their_python_twins_bit_for_bit():
    rng = np.random.default_rng(77)
    polished = numpy_rows = 0
    for i in range(600):
        dev, k, b = _wall(rng, i)
        d, _ = passivity.passivity_samples(dev)
        hk, n = k * dev.sample_time / 2, 64 * (d + 1) + 257
        grid, vals, v_pi = pk.prefix_samples(d, n, hk, b)
        g2, v2, p2 = _passivity_prefix(d, n, hk, b)
        assert _same_array(grid, g2) and _same_array(vals, v2) and v_pi == p2, (dev, k, b)
        # the brackets passivity_margin polishes (around its three largest samples), and three at random
        for j in [*np.argpartition(-vals, 2)[:3].tolist(), *rng.integers(0, grid.size, 3).tolist()]:
            lo, hi = float(grid[max(j - 1, 0)]), float(grid[min(j + 1, grid.size - 1)])
            if pk.needs_python(d, lo):
                numpy_rows += 1
                continue
            start = float(rng.uniform(lo, hi))
            got, want = pk.polish_max(d, hk, b, lo, hi, start), passivity._polish_max(d, hk, b, lo, hi, start)
            assert got == want or (math.isnan(got) and math.isnan(want)), (dev, k, b, lo, hi, start)
            polished += not math.isnan(got)
    assert polished >= 100 and numpy_rows >= 10   # both kinds of bracket were met


def test_sup_bound_equals_its_python_twin_bit_for_bit():
    """The proven bound (compiled) against tests/optim/stability/passivity_python.sup_bound, from the grid's largest
    sample and from the polished maximum alike, and p_value at random angles."""
    rng = np.random.default_rng(79)
    bisected = 0
    for i in range(400):
        dev, k, b = _wall(rng, i)
        d, _ = passivity.passivity_samples(dev)
        hk, n = k * dev.sample_time / 2, 64 * (d + 1) + 257
        grid, vals, v_pi = pk.prefix_samples(d, n, hk, b)
        j = int(np.argmax(vals))
        for start in [(float(vals[j]), float(grid[j])), (v_pi, math.pi)]:
            got = pk.sup_bound(d, n, hk, b, grid, vals, *start, pk.SUP_TOL)
            want = twin.sup_bound(d, n, hk, b, grid, vals, *start, pk.SUP_TOL)
            assert got == want, (dev, k, b)
            bisected += got[1] > start[0]
        t = float(rng.uniform(0, math.pi))
        assert pk.p_value(t, d, hk, b) == twin.p_value(t, d, hk, b)
    assert bisected >= 50   # the bound met values above the start (between samples)


def test_passivity_margin_equals_the_python_path(monkeypatch):
    """passivity_margin whole (compiled samples, rows and polish; the rows in Python where a bracket needs numpy's
    sums) against the same function with every kernel replaced by its Python twin."""
    rng = np.random.default_rng(78)
    walls = [_wall(rng, i) for i in range(400)]
    undecided = []
    compiled_rows = passivity.best_of_rows

    def spy(*args):
        out = compiled_rows(*args)
        undecided.append(not out[2])
        return out

    monkeypatch.setattr(passivity, "best_of_rows", spy)
    got = [passivity.passivity_margin(dev, k, b) for dev, k, b in walls]
    monkeypatch.setattr(passivity, "prefix_samples", _passivity_prefix)
    monkeypatch.setattr(passivity, "polish_max", passivity._polish_max)
    monkeypatch.setattr(passivity, "best_of_rows", lambda d, hk, b, grid, vals, top, v_pi: (
        *passivity._best_of_rows(d, hk, b, grid, vals, top.tolist(), v_pi), True))
    monkeypatch.setattr(passivity, "sup_bound", twin.sup_bound)
    want = [passivity.passivity_margin(dev, k, b) for dev, k, b in walls]
    assert got == want
    assert sum(c.passive for c in got) >= 40 and sum(not c.passive for c in got) >= 40
    # both kinds of wall were met: rows decided compiled, and rows handed back to Python
    assert sum(undecided) >= 10 and len(undecided) - sum(undecided) >= 200
