"""optim.stability.rigid_tail against the scan it replaces: where it says the tail [θ_r, π) holds no K > 0
crossover, the scan of that interval (optim.stability.crossovers, the exact rung's list before issue 20) finds
none either, on random rigid devices (δ from 1e-10 to 3, whole and fractional delays up to 30 samples, B = 0,
B uniform below B_max and B within 1e-4 of B_max; 2 × 1,000 devices); and it closes on nearly all of them."""

import math

import numpy as np
import pytest

from models.device import Device
from optim.stability.crossovers import positive_real_crossings
from optim.stability.fast_rigid import rigid_loop
from optim.stability.margins import _grid, critical_stiffness, loop_plant, max_stable_damping, scan_critical_stiffness
from optim.stability.rigid_tail import tail_is_clear


def _scan_tail(dev, plant, beta, lo):
    def h(theta):
        return -plant.inverse_response(theta) + beta * np.expm1(-1j * theta)

    grid = _grid(dev, plant, beta)
    grid = np.concatenate([[lo], grid[grid > lo]])
    return [c for c in positive_real_crossings(h, grid) if c.angle < math.pi]


@pytest.mark.parametrize("seed", [0, 1])
def test_a_clear_tail_is_clear_for_the_scan(seed):
    rng = np.random.default_rng(seed)
    cleared = total = 0
    for i in range(1000):
        delta = 10 ** rng.uniform(-10, 0.5)
        ds = float(rng.integers(0, 30)) if i % 2 else float(rng.uniform(0, 30))
        t, m = float(rng.choice([5e-4, 1e-3, 2e-3])), 10 ** rng.uniform(-3, 1)
        dev = Device(mass=m, damping=delta * m / t, sample_time=t, delay=ds * t)
        plant = loop_plant(dev)
        loop = rigid_loop(plant)
        if loop is None:
            continue
        kind = i % 3
        b = 0.0 if kind == 0 else max_stable_damping(dev) * (rng.uniform(0, 1) if kind == 1
                                                             else 1 - 10 ** rng.uniform(-4, -1))
        beta = b / dev.damping_scale
        total += 1
        if tail_is_clear(loop, beta):
            cleared += 1
            assert _scan_tail(dev, plant, beta, loop.theta_r) == [], (dev, b)
    assert cleared >= 0.95 * total


def test_the_list_equals_the_scans_on_the_issue_loops():
    """The crossover list of the exact rung (rising roots + cleared tail) against the scan's, entry by entry."""
    for kw, b in [({"mass": 5.4, "damping": 3.5, "delay": 0.0}, 0.0), ({"mass": 5.4, "damping": 3.5, "delay": 0.005}, 20.0),
                  ({"mass": 1.05e-3, "damping": 0.0085, "delay": 0.05}, 0.0),
                  ({"mass": 1.05e-3, "damping": 0.0085, "delay": 0.2}, 0.004),
                  ({"mass": 1.05e-3, "damping": 0.0085, "delay": 0.0037}, 0.0)]:
        dev = Device(sample_time=1e-3, **kw)
        got, ref = critical_stiffness(dev, b).crossovers, scan_critical_stiffness(dev, b).crossovers
        assert len(got) == len(ref)
        for a, c in zip(got, ref):
            assert a.frequency == pytest.approx(c.frequency, rel=1e-9)
            assert a.stiffness == pytest.approx(c.stiffness, rel=1e-12)


def test_the_list_equals_the_scans_on_random_devices_with_and_without_damping():
    """Every crossover of the fast path's list (rising roots + cleared tail) against the scan's, B = 0 and
    B up to 0.95·B_max, whole and fractional delays up to 60 samples."""
    rng = np.random.default_rng(5)
    fast = 0
    for i in range(120):
        delta, m = 10 ** rng.uniform(-8, 0.5), 10 ** rng.uniform(-3, 1)
        ds = float(rng.integers(0, 60)) if i % 2 else float(rng.uniform(0, 60))
        dev = Device(mass=m, damping=delta * m / 1e-3, sample_time=1e-3, delay=ds * 1e-3)
        b = 0.0 if i % 2 == 0 else max_stable_damping(dev) * rng.uniform(0, 0.95)
        got, ref = critical_stiffness(dev, b), scan_critical_stiffness(dev, b)
        if got.path != "fast":
            continue
        fast += 1
        assert len(got.crossovers) == len(ref.crossovers), (dev, b)
        for a, c in zip(got.crossovers, ref.crossovers):
            assert a.frequency == pytest.approx(c.frequency, rel=1e-9)
            assert a.stiffness == pytest.approx(c.stiffness, rel=1e-12)
    assert fast >= 115
