"""The largest passive stiffness of a rendered wall C(z) = K + B·V(z) + M·A(z) at a given B (general
Colgate–Schenkel with d whole samples of delay, optim.stability.passivity_rendered).

The bound is affine in K at every θ:  P(θ) = K·s(θ) + r(θ) with

    s(θ) = (T/2)·sin((d + ½)θ)/sin(θ/2)                          (the Dirichlet kernel: K's part, any filter)
    r(θ) = (T/2)·Re{(1 − e^{−jθ})·e^{−jdθ}·(B·V + M·A)}/(1 − cos θ)

and passive means b > P(θ) for every θ ∈ (0, π] (θ → 0⁺: K·T·(d + ½) − B).  So the passive K form an interval:
K < (b − r)/s where s > 0 and K > (b − r)/s where s < 0.  The largest passive K is the infimum of (b − r)/s over
s > 0, provided it exceeds every lower bound.  It is taken on the grid of rendered_required_damping, the lowest
ratios polished by a bounded scalar search; the design re-checks its answer with rendered_passivity.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import minimize_scalar

from models.device import Device
from models.velocity_filter import DEFAULT_RENDERING, Rendering
from optim.stability.passivity import passivity_samples
from optim.stability.passivity_rendered import rendered_passivity_bound

__all__ = ["largest_rendered_passive_stiffness"]


def _grid(rendering: Rendering, whole: int) -> np.ndarray:
    n = max(4096, 64 * (whole + 1))
    parts = [np.geomspace(1e-7, 1e-2, 200), np.linspace(1e-2, math.pi, n)]
    for ang in rendering.velocity.pole_angles():
        parts.append(np.clip(ang + np.linspace(-0.05, 0.05, 401), 1e-7, math.pi))
    return np.unique(np.concatenate(parts))


def largest_rendered_passive_stiffness(device: Device, damping: float, rendering: Rendering) -> tuple[float, float]:
    """(sup of the passive K [N/m], the θ [rad] that sets it; 0.0 for the limit θ → 0⁺); (0, θ) when no K ≥ 0 is
    passive at this B."""
    whole, _ = passivity_samples(device)
    b = device.damping
    grid = _grid(rendering, whole)

    def parts(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        s = rendered_passivity_bound(device, 1.0, 0.0, DEFAULT_RENDERING, whole, theta)
        r = rendered_passivity_bound(device, 0.0, damping, rendering, whole, theta)
        return s, r

    s, r = parts(grid)
    pos = s > 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(pos, (b - r) / np.where(pos, s, 1.0), np.inf)
        lower = np.where(s < 0.0, (b - r) / np.where(s < 0.0, s, 1.0), -np.inf)
    limit0 = (b + damping) / (device.sample_time * (whole + 0.5))
    best_k, best_t = limit0, 0.0
    i_best = int(np.argmin(ratio))
    if ratio[i_best] < best_k:
        best_k, best_t = float(ratio[i_best]), float(grid[i_best])
    padded = np.concatenate([[np.inf], ratio, [np.inf]])
    valleys = np.flatnonzero((ratio <= padded[:-2]) & (ratio <= padded[2:]) & np.isfinite(ratio))

    def f(x: float) -> float:
        ss, rr = parts(np.array([x]))
        return float((b - rr[0]) / ss[0]) if ss[0] > 0.0 else math.inf
    for i in valleys[np.argsort(ratio[valleys])[:6]]:
        lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
        if hi > lo:
            res = minimize_scalar(f, bounds=(lo, hi), method="bounded", options={"xatol": 1e-13 * max(lo, 1e-12)})
            if res.fun < best_k:
                best_k, best_t = float(res.fun), float(res.x)
    # where s ≤ 0 the bound needs b > r − K·|s|: a lower limit on K (or none at all where s = 0 and r ≥ b)
    k_low = float(np.max(lower)) if np.any(s < 0.0) else -math.inf
    if np.any((s == 0.0) & (r >= b)) or not best_k > max(k_low, 0.0):
        return 0.0, best_t
    return best_k, best_t
