"""Closed-loop state matrix of the stiffness loop with any rendered wall, built without the crossover scan's code.

The independent side of ``verify`` for C(z) = K + B·V(z) + M·A(z) (optim/verification.py).  The velocity filter's
coefficients are written out again here from its specification (models.velocity_filter's pydantic kinds, not its
VelocityTransfer), the controller is realised as one difference equation on the measured position,

    D(w)·u[k] = −P(w)·y[k],   P = α·D + β·N̂ + μ·N̂·(1 − w),   N̂ = T·N (dimensionless),  w = z⁻¹,

with its past positions and past forces as shift registers, and the plant is optim.stability.closed_loop's
(its continuous model written out again, one augmented matrix exponential, the fractional delay in two input
matrices).  The matrix is in the delta form Q = M − I of optim.stability.closed_loop.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import signal

from models.velocity_filter import BackwardDifference, LowPass, MovingAverage, TransferFunctionFilter
from optim.stability.closed_loop import SampledPlant, add_delay_chain, add_plant_rows, plant_response

__all__ = ["filter_polynomials", "rendered_closed_loop", "rendered_controller", "rendered_states",
           "rendered_return_difference", "filter_poles"]


def filter_polynomials(spec, sample_time: float) -> tuple[np.ndarray, np.ndarray]:
    """(N̂, D): T·N and D of V = N/D in ascending powers of z⁻¹, D[0] = 1, from the filter's specification."""
    t = sample_time
    if spec is None or isinstance(spec, BackwardDifference):
        return np.array([1.0, -1.0]), np.array([1.0])
    if isinstance(spec, LowPass):
        if spec.order == 1:
            a = math.exp(-2.0 * math.pi * spec.cutoff_hz * t)
            return np.array([1.0 - a, -(1.0 - a)]), np.array([1.0, -a])
        b, a = signal.butter(2, spec.cutoff_hz, btype="low", analog=False, fs=1.0 / t)
        return np.polymul([1.0, -1.0], b / a[0]), a / a[0]
    if isinstance(spec, MovingAverage):
        n = spec.samples
        num = np.zeros(n + 1)
        num[0], num[n] = 1.0 / n, -1.0 / n
        return num, np.array([1.0])
    if isinstance(spec, TransferFunctionFilter):
        den = np.asarray(spec.denominator, dtype=float)
        return np.asarray(spec.numerator, dtype=float) * t / den[0], den / den[0]
    raise TypeError(f"unknown velocity filter {spec!r}")


def filter_poles(spec, sample_time: float) -> np.ndarray:
    """The filter's poles in z (roots of Σ D_k z^{n−k})."""
    _, den = filter_polynomials(spec, sample_time)
    return np.roots(den) if den.size > 1 else np.zeros(0)


def _controller(spec, sample_time: float, alpha: float, beta: float, mu: float) -> tuple[np.ndarray, np.ndarray]:
    num, den = filter_polynomials(spec, sample_time)
    size = max(den.size, num.size + 1)
    p = np.zeros(size)
    p[:den.size] += alpha * den
    p[:num.size] += beta * num
    p[:num.size] += mu * num
    p[1:num.size + 1] -= mu * num
    return p, den


#: (P, D) of the controller's difference equation D(w)·u = −P(w)·y, ascending powers of w = z⁻¹ (dimensionless)
rendered_controller = _controller


def rendered_states(plant: SampledPlant, spec, sample_time: float) -> int:
    """The closed loop's state count (plant, past positions, past forces)."""
    num, den = filter_polynomials(spec, sample_time)
    chain = max(plant.d + (1 if plant.f > 0.0 else 0), den.size - 1)
    return plant.e.shape[0] + num.size + chain


def rendered_closed_loop(plant: SampledPlant, spec, sample_time: float, alpha: float, beta: float,
                         mu: float) -> np.ndarray:
    """Q = M − I with u[k] = −Σ p_i y[k−i] − Σ_{i≥1} D_i u[k−i]; state [x, y[k−1..k−np+1], u[k−1..k−L]]."""
    p, den = _controller(spec, sample_time, alpha, beta, mu)
    n = plant.e.shape[0]
    npast = p.size - 1
    chain = max(plant.d + (1 if plant.f > 0.0 else 0), den.size - 1)
    iy, iu = n, n + npast
    size = n + npast + chain
    u = np.zeros(size)
    u[:n] = -p[0] * plant.c
    for i in range(1, p.size):
        u[iy + i - 1] -= p[i]
    for i in range(1, den.size):
        u[iu + i - 1] -= den[i]
    q = np.zeros((size, size))
    add_plant_rows(q, plant, u, iu)
    for j in range(npast):                      # y[k−1−j] next = y[k−j]
        q[iy + j, iy + j] -= 1.0
        if j == 0:
            q[iy, :n] += plant.c
        else:
            q[iy + j, iy + j - 1] += 1.0
    add_delay_chain(q, u, iu, chain)
    return q


def rendered_return_difference(plant: SampledPlant, spec, sample_time: float, alpha: float, beta: float,
                               mu: float, theta: np.ndarray) -> np.ndarray:
    """F(e^{jθ}) = 1 + C(z)·G(z), C from the difference equation's polynomials (argument principle)."""
    p, den = _controller(spec, sample_time, alpha, beta, mu)
    g = plant_response(plant, theta)
    zinv = np.exp(-1j * theta)
    ctrl = np.polyval(p[::-1], zinv) / np.polyval(den[::-1], zinv)
    return 1.0 + ctrl * g
