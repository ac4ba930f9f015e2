"""Passivity of any rendered wall C(z) = K + B·V(z) + M·A(z) by the general Colgate–Schenkel condition with delay.

With d whole samples of loop delay the wall is passive when (ARCHITECTURE.md, "The rendered virtual environment")

    b > (T/2)·sup over θ ∈ (0, π] of Re{(1 − e^{−jθ})·e^{−jdθ}·C(e^{jθ})}/(1 − cos θ).

For the backward difference it is optim.stability.passivity's delayed form (b > (KT/2)·s_d(θ) − B·cos((d+1)θ)).
With a first-order filter mapped by backward differences (a = τ/(τ + T)), no delay and B ≥ 0 the supremum sits at
θ = π and is K·T/2 + B·T/(T + 2τ) (Brown 1995, appendix A).  As θ → 0⁺ the bound tends to K·T·(d + ½) − B for
every velocity estimate (V_n = jθ + O(θ²)) and any virtual mass (M·A is O(θ²) and its real part O(θ⁴)).
A fractional delay is rounded up to the next whole sample (conservative), as for today's wall.

The supremum is taken on a dense grid (log-spaced towards 0, ≥ 64 points per turn of the delay's phase, and
clusters at the filter's pole angles), each of the 6 highest local maxima polished by a bounded scalar search,
the ends θ = π and θ → 0⁺ evaluated exactly.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import minimize_scalar

from models.device import Device
from models.velocity_filter import Rendering
from optim.stability.passivity import PassivityCheck, passivity_samples

__all__ = ["rendered_passivity", "rendered_passivity_bound", "rendered_required_damping"]


def rendered_passivity_bound(device: Device, stiffness: float, damping: float, rendering: Rendering, whole: int,
                             theta: np.ndarray) -> np.ndarray:
    """(T/2)·Re{(1 − e^{−jθ})·e^{−jdθ}·C(e^{jθ})}/(1 − cos θ) [N·s/m]."""
    t, m = device.sample_time, device.mass
    a = -np.expm1(-1j * theta)
    ctrl = stiffness + (m / (t * t)) * rendering.controller_response(theta, damping * t / m, rendering.mass / m)
    den = 2.0 * np.sin(0.5 * theta) ** 2
    return (0.5 * t) * (a * np.exp(-1j * whole * theta) * ctrl).real / den


def rendered_required_damping(device: Device, stiffness: float, damping: float, rendering: Rendering,
                              whole: int) -> tuple[float, float]:
    """(sup of the bound [N·s/m], its θ [rad]; 0.0 for the limit θ → 0⁺) with ``whole`` samples of delay."""
    n = max(4096, 64 * (whole + 1))
    parts = [np.geomspace(1e-7, 1e-2, 200), np.linspace(1e-2, math.pi, n)]
    for ang in rendering.velocity.pole_angles():
        parts.append(np.clip(ang + np.linspace(-0.05, 0.05, 401), 1e-7, math.pi))
    grid = np.unique(np.concatenate(parts))
    vals = rendered_passivity_bound(device, stiffness, damping, rendering, whole, grid)
    padded = np.concatenate([[-np.inf], vals, [-np.inf]])
    peaks = np.flatnonzero((vals >= padded[:-2]) & (vals >= padded[2:]))
    i_best = int(np.argmax(vals))
    best_t, best_v = float(grid[i_best]), float(vals[i_best])
    for i in peaks[np.argsort(vals[peaks])[-6:]]:
        lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
        if hi > lo:
            r = minimize_scalar(lambda x: -float(rendered_passivity_bound(device, stiffness, damping, rendering, whole,
                                                        np.array([x]))[0]),
                                bounds=(lo, hi), method="bounded", options={"xatol": 1e-13 * max(lo, 1e-12)})
            if -r.fun > best_v:
                best_t, best_v = float(r.x), float(-r.fun)
    limit = stiffness * device.sample_time * (whole + 0.5) - damping
    if limit >= best_v:
        return limit, 0.0
    return best_v, best_t


def rendered_passivity(device: Device, stiffness: float, damping: float, rendering: Rendering) -> PassivityCheck:
    """Whether (K, B, M, filter) is passive on this device: b above the general bound."""
    whole, conservative = passivity_samples(device)
    req, theta = rendered_required_damping(device, stiffness, damping, rendering, whole)
    return PassivityCheck(passive=bool(device.damping > req), required_damping=req, delay_samples_used=whole,
                          conservative=conservative, worst_angle=theta)
