"""Independent checks of a robust design: corners + random points, and a dense (B, box-grid) search."""

from __future__ import annotations

import itertools

import numpy as np
from scipy.optimize import minimize_scalar

from optim.margins import max_stable_damping
from optim.robust.batch import batch_critical_stiffness
from optim.robust.box import UncertaintyBox


def min_margin_db(box: UncertaintyBox, k: float, b: float, n_random: int = 2000, seed: int = 99) -> float:
    """Smallest 20·log10(K_cr/K) over every corner and n_random uniform points of the box."""
    rng = np.random.default_rng(seed)
    pts = np.concatenate([box.corners(), box.lower + rng.random((n_random, box.dim)) * (box.upper - box.lower)])
    kcr = batch_critical_stiffness(box.devices(pts), b).critical_stiffness
    assert kcr.size == len(box.corners()) + n_random
    with np.errstate(divide="ignore"):
        return float(np.min(20 * np.log10(kcr / k)))


def dense_best(box: UncertaintyBox, gain: float, per_axis: int = 9, b_points: int = 41,
               b_cap: float = np.inf) -> tuple[float, float]:
    """(best K, its B) of max_B g·min_{grid} K_cr(B; p): a B scan and a bounded refinement of the best B.

    The grid minimum is ≥ the true minimum over the box, so this K is an upper bound (up to the grid's
    fineness) of what any design can safely reach: a design well below it is over-conservative.
    """
    axes = [np.linspace(lo, hi, per_axis) if hi > lo else np.array([lo]) for lo, hi in zip(box.lower, box.upper)]
    pts = np.array(list(itertools.product(*axes)))
    devices = box.devices(pts)
    upper = min(min(max_stable_damping(d) for d in box.devices(box.corners())), b_cap)

    def worst(b: float) -> float:
        return gain * float(np.min(batch_critical_stiffness(devices, b).critical_stiffness))

    grid = np.linspace(0.0, upper, b_points)
    grid[-1] = upper * (1 - 1e-9) if np.isinf(b_cap) or b_cap > upper else upper
    vals = np.array([worst(b) for b in grid])
    i = int(np.argmax(vals))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    res = minimize_scalar(lambda b: -worst(b), bounds=(lo, hi), method="bounded", options={"xatol": 1e-9 * upper})
    return (float(-res.fun), float(res.x)) if -res.fun > vals[i] else (float(vals[i]), float(grid[i]))
