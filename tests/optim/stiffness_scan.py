"""Independent comparator for the stiffness design: a dense scan of B with the exact K_cr, then refinement.

It shares nothing with optim.stiffness except the exact analysis it is meant to agree with
(optim.stability.margins.critical_stiffness) and the passivity module (itself checked against a dense θ scan).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import minimize_scalar

from models.device import Device
from optim.errors import InputError
from optim.stability.margins import critical_stiffness, max_stable_damping
from optim.stability.passivity import max_passive_stiffness


def objective(device: Device, req, b: float) -> float:
    """The best K at this B; 0 where no claim can be made: no passive K (then K_cr is not needed), or the exact
    analysis refuses this B with a 422 (an undamped cable whose closed loop it cannot confirm at B)."""
    k = math.inf
    if req.passivity:
        k = max_passive_stiffness(device, b)
        if k <= 0.0:
            return 0.0
    try:
        k = min(k, req.gain_factor * critical_stiffness(device, b).critical_stiffness)
    except InputError:
        return 0.0
    for cap in req.stiffness_caps().values():
        k = min(k, cap)
    return k


def scan_best(device: Device, req, points: int = 121) -> tuple[float, float]:
    """(best K, its B) by a dense B scan (exact K_cr at every point) and bounded refinement of the 3 best."""
    try:
        b_max = max_stable_damping(device)
    except InputError:
        # B_max refused (an undamped cable whose mode moves along the circle): scan B up to 10·m/T, far above
        # any B_max of a rigid device of the same mass (~2m/T), and say nothing beyond it
        b_max = 10.0 * device.mass / device.sample_time
    upper = min([b_max, *req.damping_caps(device.sample_time).values()])
    grid = np.concatenate([np.linspace(0.0, upper, points), upper * np.geomspace(1e-4, 3e-2, 12)])
    if req.passivity:
        # P(π) = (−1)^d·(K·T/2 + B) and, where the kernel vanishes, −B·cos((d+1)θ) must stay below b: no passive
        # wall has B ≥ 2b, and with b ≪ B_max that band is missed by the grid above (issue 17)
        band = min(upper, 2.0 * device.damping)
        grid = np.concatenate([grid, np.linspace(0.0, band, 61), band * np.geomspace(1e-6, 1e-2, 9)])
    grid = np.unique(grid[grid <= upper])
    vals = np.array([objective(device, req, b) for b in grid])
    best_k, best_b = float(vals.max()), float(grid[int(vals.argmax())])
    for i in np.argsort(vals)[::-1][:3]:
        lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
        res = minimize_scalar(lambda b: -objective(device, req, b), bounds=(lo, hi), method="bounded",
                              options={"xatol": 1e-10 * max(upper, 1e-300)})
        if -res.fun > best_k:
            best_k, best_b = float(-res.fun), float(res.x)
    return best_k, best_b
