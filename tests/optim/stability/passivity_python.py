"""optim.stability.passivity's sampling of P as it ran in Python (numpy): the twin that
optim.stability.passivity_kernel.prefix_samples is held to bit for bit (test_passivity_kernel.py).  The polish's
twin is passivity._polish_max itself (still run where its numpy branch is needed)."""

from __future__ import annotations

import math

import numpy as np


def _passivity_prefix(d: int, n: int, hk: float, damping: float) -> tuple[np.ndarray, np.ndarray, float]:
    """(θ, P(θ)) on the part of ``_grid(d)`` (n samples) where P may reach its maximum, and P(π).

    s_d = sin((d+1)θ)·cot(θ/2) − cos((d+1)θ), so P = hk·cot(θ/2)·sin u − (hk + B)·cos u with u = (d+1)θ, and
    P(θ) ≤ E(θ) = √(hk²·cot²(θ/2) + (hk + B)²), which falls with θ.  With V the largest of P(π) and the first
    samples (the first lobes), every sample past θ_c = 2·atan(hk/√(V² − (hk + B)²)) lies below V: it can neither
    be the maximum nor refine to it.  The kept samples are the grid's own (linspace's arange·step), two past θ_c
    so that each kept maximum has both grid neighbours."""
    step = math.pi / (n - 1)

    def samples(lo: int, hi: int) -> tuple[np.ndarray, np.ndarray]:
        theta = np.arange(lo, hi) * step
        if hi == n:
            theta[-1] = math.pi                              # as linspace sets its end point
        # kernel's operations elementwise, its θ = 0 limit set apart (no masks, no errstate: a third of the cost)
        s = np.empty_like(theta)
        pos = theta[1:] if lo == 0 else theta
        np.divide(np.sin((d + 0.5) * pos), np.sin(pos / 2), out=s[1:] if lo == 0 else s)
        if lo == 0:
            s[0] = 2 * d + 1.0
        return theta, hk * s - damping * np.cos((d + 1) * theta)

    # P(π) by kernel's own operations in plain floats (math's sin/cos are numpy's, bit for bit)
    v_pi = hk * (math.sin((d + 0.5) * math.pi) / math.sin(math.pi / 2)) - damping * math.cos((d + 1) * math.pi)
    first = min(n, 3 * 64 + 3)
    grid, vals = samples(0, first)
    v_low, c = max(float(vals.max()), v_pi), hk + damping
    keep = n
    if v_low > c:
        keep = min(n, int(2.0 * math.atan(hk / math.sqrt((v_low - c) * (v_low + c))) / step) + 3)
    if keep > first:
        more_t, more_v = samples(first, keep)
        grid, vals = np.concatenate([grid, more_t]), np.concatenate([vals, more_v])
    return grid, vals, v_pi
