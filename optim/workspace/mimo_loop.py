"""The full N-DOF sampled wall loop, built without the modal decomposition (no RigidZOH, no crossover scan), for
`verify` of the workspace design; tests/optim/workspace/mimo_loop.py is its independent twin (the tests' oracle).

The joint-space plant M q̈ + D q̇ = Jᵀ f with three Cartesian force inputs and three position
outputs, its exact ZOH with a fractional input delay from one augmented matrix exponential (scipy.linalg.expm), the
Cartesian wall f_k = −K n nᵀ y_k − (B/T) n nᵀ (y_k − y_{k−1}) and the delay line as states.  Its eigenvalues decide
stability, less the z = 1 poles of undamped joints the wall does not move (:func:`unmoved`: left out exactly, by
deflating the invariant subspace, not by a tolerance on |z|).
"""

from __future__ import annotations

__all__ = ["closed_loop_matrix", "wall_spectral_radius", "rendered_closed_loop_matrix", "rendered_wall_spectral_radius",
           "unmoved"]

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


def unmoved(jac: np.ndarray, damping_q: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """An orthonormal basis (columns) of the joint velocities no wall along n moves: Dv = 0 and nᵀJv = 0 (undamped
    joints the wall does not see).  Each is a state (p = 0, v) the loop maps to itself: an eigenvalue exactly 1
    that is no part of the wall's loop (its computed copy lands at 1 ± 1e-16 and would decide "unstable")."""
    nq = len(damping_q)
    zero = np.flatnonzero(np.asarray(damping_q) == 0.0)
    if not zero.size:
        return np.zeros((nq, 0))
    row = (normal @ jac)[zero]                     # nᵀJ on the undamped joints
    scale = float(np.max(np.abs(normal @ jac))) if nq else 0.0
    keep = np.eye(len(zero))
    if np.linalg.norm(row) > 1e-14 * max(scale, 1e-300):
        _, _, vt = np.linalg.svd(row[None, :])
        keep = vt[1:].T                            # the undamped joints' combinations with nᵀJv = 0
    out = np.zeros((nq, keep.shape[1]))
    out[zero] = keep
    return out


def _deflated(matrix: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """The loop's matrix on the quotient by the invariant states (0, v), v in ``basis`` (state rows 1…nq are the
    joint velocities): Qᵀ·matrix·Q with Q orthogonal, its first columns those states, less their rows and columns."""
    k = basis.shape[1]
    if k == 0:
        return matrix
    s = np.zeros((matrix.shape[0], k))
    s[1:1 + basis.shape[0]] = basis
    q, _ = np.linalg.qr(np.concatenate([s, np.eye(matrix.shape[0])], axis=1))
    return (q.T @ matrix @ q)[k:, k:]


def wall_spectral_radius(mass: np.ndarray, jac: np.ndarray, damping_q: np.ndarray, normal: np.ndarray,
                         stiffness: float, damping: float, sample_time: float, delay: float) -> float:
    """max |z| over the closed loop's eigenvalues, less the unmoved z = 1 poles (:func:`unmoved`)."""
    loop = closed_loop_matrix(mass, jac, damping_q, normal, stiffness, damping, sample_time, delay)
    eig = np.linalg.eigvals(_deflated(loop, unmoved(jac, damping_q, np.asarray(normal, dtype=float))))
    return float(np.max(np.abs(eig)))


def rendered_closed_loop_matrix(mass: np.ndarray, jac: np.ndarray, damping_q: np.ndarray, normal: np.ndarray,
                                stiffness: float, damping: float, sample_time: float, delay: float, spec,
                                virtual_mass: float = 0.0) -> np.ndarray:
    """The loop of :func:`closed_loop_matrix` with the rendered wall C(z) = K + B·V(z) + M·A(z) along n: the filter's
    and the virtual mass's states as one difference equation on the penetration p = nᵀy (its coefficients written
    out from the filter's specification by optim.stability.closed_loop_rendered.filter_polynomials, not the
    crossover scan's V(z)):  D(w)·f[k] = −(K·D(w) + (B/T)·N̂(w) + (M/T²)·N̂(w)(1 − w))·p[k], u = n·f.
    State: x (penetration, joint velocities), p[k−1 … k−P], f[k−1 … k−L]."""
    from optim.stability.closed_loop_rendered import filter_polynomials

    t = sample_time
    num, den = filter_polynomials(spec, t)
    p = np.zeros(max(den.size, num.size + 1))
    p[:den.size] += stiffness * den
    p[:num.size] += (damping / t) * num + (virtual_mass / t ** 2) * num
    p[1:num.size + 1] -= (virtual_mass / t ** 2) * num
    nq = mass.shape[0]
    minv = np.linalg.inv(mass)
    a = np.zeros((1 + nq, 1 + nq))
    a[0, 1:] = normal @ jac
    a[1:, 1:] = -minv @ np.diag(damping_q)
    b = np.zeros((1 + nq, 1))
    b[1:, 0] = minv @ jac.T @ normal
    samples = delay / t
    d = int(math.floor(samples + 1e-12))
    frac = samples - d
    if frac < 1e-12:
        frac = 0.0
    phi, g_now, g_prev = _zoh_pieces(a, b, t, frac)
    nx = 1 + nq
    npast = p.size - 1
    nf = max(d + 1, den.size - 1)
    ip, jf = nx, nx + npast
    size = nx + npast + nf
    f_now = np.zeros(size)
    f_now[0] = -p[0]
    for i in range(1, p.size):
        f_now[ip + i - 1] -= p[i]
    for i in range(1, den.size):
        f_now[jf + i - 1] -= den[i]

    def f_past(i: int) -> np.ndarray:          # f[k−1−i]
        e = np.zeros(size)
        e[jf + i] = 1.0
        return e
    applied = f_now if d == 0 else f_past(d - 1)
    out = np.zeros((size, size))
    out[:nx, :nx] = phi
    out[:nx] += np.outer(g_now[:, 0], applied) + np.outer(g_prev[:, 0], f_past(d))
    out[ip, 0] = 1.0                            # p[k] = x[0]
    for j in range(1, npast):
        out[ip + j, ip + j - 1] = 1.0
    out[jf] = f_now
    for j in range(1, nf):
        out[jf + j, jf + j - 1] = 1.0
    return out


def rendered_wall_spectral_radius(mass: np.ndarray, jac: np.ndarray, damping_q: np.ndarray, normal: np.ndarray,
                                  stiffness: float, damping: float, sample_time: float, delay: float, spec,
                                  virtual_mass: float = 0.0) -> float:
    """max |z| over the rendered wall's closed loop (:func:`rendered_closed_loop_matrix`)."""
    q = rendered_closed_loop_matrix(mass, jac, damping_q, normal, stiffness, damping, sample_time, delay, spec,
                                    virtual_mass)
    q = _deflated(q, unmoved(jac, damping_q, np.asarray(normal, dtype=float)))
    return float(np.max(np.abs(np.linalg.eigvals(q))))
