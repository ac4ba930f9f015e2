"""Passivity of the virtual wall (Colgate–Schenkel), with the loop delay (ARCHITECTURE.md).

Eq. 3 of the chapter, b > KT/2 + B, holds only without delay.  With d whole
samples of delay the same theorem applied to z^(-d)·C(z) gives

    b > P(θ) = (K·T/2)·sin((d+½)θ)/sin(θ/2) − B·cos((d+1)θ)   for every θ ∈ (0, π],

which is eq. 3 at d = 0 and b > K(T/2 + t_d) at B = 0.  A fractional delay is
rounded *up* to the next whole sample: conservative, and the answer says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from models.device import Device
from models.discretize import split_delay

__all__ = ["PassivityCheck", "passivity_samples", "passivity_margin", "is_passive", "max_passive_stiffness"]


@dataclass(frozen=True)
class PassivityCheck:
    passive: bool
    required_damping: float
    """max over θ of P(θ) [N·s/m]: the physical damping passivity needs."""
    delay_samples_used: int
    """whole samples of delay used (a fractional delay is rounded up)."""
    conservative: bool
    """True when a fractional delay was rounded up."""


def passivity_samples(device: Device) -> tuple[int, bool]:
    d, f = split_delay(device.delay_samples)
    return (d + 1, True) if f > 0 else (d, False)


def _grid(d: int) -> np.ndarray:
    return np.linspace(0.0, math.pi, 64 * (d + 1) + 257)[1:]


def _kernel(theta: np.ndarray, d: int) -> tuple[np.ndarray, np.ndarray]:
    """sin((d+½)θ)/sin(θ/2) (the Dirichlet kernel, 2d+1 at θ → 0) and cos((d+1)θ)."""
    return np.sin((d + 0.5) * theta) / np.sin(theta / 2), np.cos((d + 1) * theta)


def passivity_margin(device: Device, stiffness: float, damping: float) -> PassivityCheck:
    """max over θ ∈ (0, π] of P(θ), refined around the best grid point."""
    d, conservative = passivity_samples(device)
    half_t = device.sample_time / 2

    def p(theta: np.ndarray) -> np.ndarray:
        s, c = _kernel(theta, d)
        return stiffness * half_t * s - damping * c

    grid = _grid(d)
    vals = p(grid)
    i = int(np.argmax(vals))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    best = float(vals[i])
    if hi > lo:
        res = minimize_scalar(lambda t: -float(p(np.array([t]))[0]), bounds=(lo, hi), method="bounded",
                              options={"xatol": 1e-13})
        best = max(best, -float(res.fun))
    # θ → 0⁺ (the kernel's limit) is the supremum for B = 0: include it exactly.
    best = max(best, stiffness * half_t * (2 * d + 1) - damping)
    return PassivityCheck(device.damping > best, best, d, conservative)


def is_passive(device: Device, stiffness: float, damping: float) -> bool:
    return passivity_margin(device, stiffness, damping).passive


def max_passive_stiffness(device: Device, damping: float) -> float:
    """Largest K [N/m] with b ≥ P(θ) for all θ; 0 when even K = 0 is not passive.

    P is linear in K, so K_max = min over θ with kernel > 0 of (b + B·cos((d+1)θ)) / ((T/2)·kernel),
    subject to b + B·cos((d+1)θ) ≥ 0 wherever the kernel ≤ 0.
    """
    d, _ = passivity_samples(device)
    b, half_t = device.damping, device.sample_time / 2
    theta = np.concatenate([_grid(d), [1e-12]])
    s, c = _kernel(theta, d)
    slack = b + damping * c
    if np.any((s <= 0) & (slack < 0)):
        return 0.0
    pos = s > 0
    ratios = slack[pos] / (half_t * s[pos])
    k = float(np.min(ratios))
    if k <= 0:
        return 0.0
    # refine the minimising θ continuously
    j = int(np.argmin(ratios))
    th = theta[pos][j]
    step = math.pi / (64 * (d + 1) + 256)
    lo, hi = max(th - step, 1e-12), min(th + step, math.pi)

    def ratio(t: float) -> float:
        ss, cc = _kernel(np.array([t]), d)
        return float((b + damping * cc[0]) / (half_t * ss[0])) if ss[0] > 0 else math.inf

    res = minimize_scalar(ratio, bounds=(lo, hi), method="bounded", options={"xatol": 1e-13})
    return max(0.0, min(k, float(res.fun)))
