"""The full N-DOF sampled wall loop, built without the modal decomposition (no RigidZOH, no crossover scan), for
`verify` of the workspace design; tests/optim/workspace/mimo_loop.py is its independent twin (the tests' oracle).

The joint-space plant M q̈ + D q̇ = Jᵀ f with three Cartesian force inputs and three position
outputs, its exact ZOH with a fractional input delay from one augmented matrix exponential (scipy.linalg.expm), the
Cartesian wall f_k = −K n nᵀ y_k − (B/T) n nᵀ (y_k − y_{k−1}) and the delay line as states.  Its eigenvalues decide
stability.
"""

from __future__ import annotations

__all__ = ["closed_loop_matrix", "wall_spectral_radius"]

import math

import numpy as np
import scipy.linalg


def _zoh_pieces(a: np.ndarray, b: np.ndarray, t: float, frac: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(Φ, Γa, Γb): x⁺ = Φx + Γa·u_now + Γb·u_prev when the input switches a fraction ``frac`` into the period."""
    n, m = b.shape
    big = np.zeros((n + m, n + m))
    big[:n, :n], big[:n, n:] = a, b

    def integral(tau: float) -> tuple[np.ndarray, np.ndarray]:
        e = scipy.linalg.expm(big * tau)
        return e[:n, :n], e[:n, n:]            # e^{Aτ}, ∫₀^τ e^{As} ds B

    phi, _ = integral(t)
    e_late, g_late = integral((1.0 - frac) * t)
    _, g_early = integral(frac * t)
    return phi, g_late, e_late @ g_early


def closed_loop_matrix(mass: np.ndarray, jac: np.ndarray, damping_q: np.ndarray, normal: np.ndarray,
                       stiffness: float, damping: float, sample_time: float, delay: float) -> np.ndarray:
    # states: the penetration along n, p = nᵀJq, and the joint velocities v.  The joint positions orthogonal to
    # Jᵀn feed nothing back (positions enter only through the wall, which reads nᵀJq): they are pure integrators
    # outside the loop, left out exactly.  y = n·p is the Cartesian position the wall sees.
    nq = mass.shape[0]
    minv = np.linalg.inv(mass)
    a = np.zeros((1 + nq, 1 + nq))
    a[0, 1:] = normal @ jac
    a[1:, 1:] = -minv @ np.diag(damping_q)
    b = np.zeros((1 + nq, 3))
    b[1:, :] = minv @ jac.T
    c = np.zeros((3, 1 + nq))
    c[:, 0] = normal
    samples = delay / sample_time
    d = int(math.floor(samples + 1e-12))
    frac = samples - d
    if frac < 1e-12:
        frac = 0.0
    phi, g_now, g_prev = _zoh_pieces(a, b, sample_time, frac)
    nn = np.outer(normal, normal)
    # state: x (2nq), y_{k-1} (3), u_{k-1} … u_{k-d-1} (3(d+1))
    nx = 1 + nq
    size = nx + 3 + 3 * (d + 1)
    u_now = np.zeros((3, size))                 # u_k as a row map of the state
    u_now[:, :nx] = -(stiffness + damping / sample_time) * nn @ c
    u_now[:, nx:nx + 3] = (damping / sample_time) * nn

    def buf(i: int) -> np.ndarray:              # u_{k-1-i} picked from the state
        sel = np.zeros((3, size))
        sel[:, nx + 3 + 3 * i: nx + 6 + 3 * i] = np.eye(3)
        return sel

    applied = u_now if d == 0 else buf(d - 1)   # u_{k-d}
    older = buf(d)                              # u_{k-d-1}
    out = np.zeros((size, size))
    out[:nx, :nx] = phi
    out[:nx] += g_now @ applied + g_prev @ older
    out[nx:nx + 3, :nx] = c
    out[nx + 3:nx + 6] = u_now
    for i in range(d):
        out[nx + 6 + 3 * i: nx + 9 + 3 * i] = buf(i)
    return out


def wall_spectral_radius(mass: np.ndarray, jac: np.ndarray, damping_q: np.ndarray, normal: np.ndarray,
                         stiffness: float, damping: float, sample_time: float, delay: float) -> float:
    """max |z| over the closed loop's eigenvalues."""
    eig = np.linalg.eigvals(closed_loop_matrix(mass, jac, damping_q, normal, stiffness, damping, sample_time, delay))
    return float(np.max(np.abs(eig)))
