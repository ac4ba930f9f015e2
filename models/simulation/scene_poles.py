"""The exact verdict of a linear scene: the poles of its sampled closed loop.

A linear scene (no relay, quantization, saturation or Coulomb friction) is the
recursion ζ[k+1] = A ζ[k] + b w[k] of models/sim_loop.closed_loop_matrices:
plant (rigid or cable, with the human and the force-sensor filter when the scene
names them), exact ZOH, the delay line with its fractional part, the wall
controller and the feedforward filter.  Its free motion decays iff every
eigenvalue of A is inside the unit circle, whatever the trajectory shows.

Rounding: LAPACK's eigenvalues (of A balanced by an exact diagonal scaling) are
exact for a matrix within ~n·ε·‖A‖ of A, so
each |z_i| is known to within n·ε·‖A‖_F / s_i (s_i = |y_iᴴx_i|/(‖y_i‖‖x_i‖), the
eigenvalue's condition).  A pole is outside the circle only when its whole
interval is.  The loop is stable when every interval is inside, or, when some
poles near 0 are too ill-conditioned for the first-order bound (a delay line is
nearly a Jordan block, or every pole is near 0), when a
Lyapunov function V = xᵀPx (AᵀPA - P = -I) decreases beyond rounding.
Otherwise the answer is ``marginal``, never a guess.

Without wall stiffness (K = 0 and no grasp stiffness) shifting every position by
the same amount changes nothing: z = 1 is then an exact pole that only holds an
offset (the device stays where it stopped).  That one pole is set aside and said.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.linalg import eig, eigvalsh, matrix_balance, solve_discrete_lyapunov

__all__ = ["ScenePoles", "closed_loop_poles", "MAX_EXACT_STATES", "POLE_FLOOR"]

#: Dense eigenvalues cost O(n³): ~0.2 s at 600 states on a quiet core.  Larger loops (a delay
#: line of more than ~590 samples) get no exact verdict, and the answer says so.
MAX_EXACT_STATES = 600
#: Smallest rounding interval on |z| (the matrix entries themselves come from expm).
POLE_FLOOR = 1e-12


@dataclass(frozen=True)
class ScenePoles:
    """Closed-loop poles of a linear scene and the exact verdict they give."""

    state: Literal["stable", "unstable", "marginal"]
    """stable: every pole inside |z| < 1; unstable: one outside; marginal: one on the circle within rounding."""
    spectral_radius: float
    """max |z_i| [-] (without the free-position pole when it is set aside)."""
    dominant_modulus: float
    """|z| of the dominant pole [-]."""
    dominant_angle: float
    """arg z ∈ [0, π] of the dominant pole [rad per sample]."""
    dominant_frequency: float
    """arg z / T [rad/s]."""
    growth_rate: float
    """ln|z| / T of the dominant pole [1/s] (< 0 decays)."""
    rounding: float
    """[-] the half-width of the interval known to hold |z| of the dominant pole."""
    states: int
    """size of the closed-loop state matrix."""
    free_position_pole: bool
    """an exact pole at z = 1 (no wall stiffness: the position offset) was set aside."""
    reason: str
    method: str = "eigenvalues of the closed-loop state matrix (LAPACK geev, with condition numbers)"


def _free_position_pole(eigs: np.ndarray) -> int | None:
    i = int(np.argmin(np.abs(eigs - 1.0)))
    return i if abs(eigs[i] - 1.0) < 1e-6 else None


def _lyapunov_certificate(a: np.ndarray) -> bool:
    """True when V(x) = xᵀPx with AᵀPA - P = -I is a Lyapunov function beyond rounding: P ≻ 0 and
    P - AᵀPA ≻ 0 by more than the rounding of forming it.  Then every eigenvalue of A is inside."""
    try:
        p = solve_discrete_lyapunov(a.T, np.eye(a.shape[0]))
    except (np.linalg.LinAlgError, ValueError):
        return False
    p = 0.5 * (p + p.T)
    if not np.all(np.isfinite(p)):
        return False
    m = p - a.T @ p @ a
    n = a.shape[0]
    slack = 10 * n * np.finfo(float).eps * (1 + np.linalg.norm(a, 2)) ** 2 * np.linalg.norm(p, 2)
    return bool(eigvalsh(p)[0] > slack and eigvalsh(0.5 * (m + m.T))[0] > slack)


def closed_loop_poles(a: np.ndarray, sample_time: float, translation_invariant: bool) -> ScenePoles | None:
    """Exact verdict from A (module docstring); None when A has more than MAX_EXACT_STATES states."""
    n = a.shape[0]
    if n > MAX_EXACT_STATES:
        return None
    # Physical units make A badly scaled (K + B/T next to 1): balance it first.  The scaling is by powers
    # of two, so it is exact and leaves the eigenvalues unchanged, but shrinks ‖A‖ and the rounding bound.
    ab, _ = matrix_balance(a, permute=False)
    w, vl, vr = eig(ab, left=True, right=True)
    norms = np.linalg.norm(vl, axis=0) * np.linalg.norm(vr, axis=0)
    cond = np.abs(np.sum(vl.conj() * vr, axis=0)) / np.where(norms > 0, norms, 1.0)
    width = np.maximum(n * np.finfo(float).eps * np.linalg.norm(ab) / np.maximum(cond, 1e-300), POLE_FLOOR)
    keep = np.ones(n, dtype=bool)
    free = False
    deflated = ab
    if translation_invariant:
        i = _free_position_pole(w)
        if i is not None:
            keep[i], free = False, True
            # Wielandt deflation (for the Lyapunov check only): the pole at 1 moves to 0, the others stay
            right, left = vr[:, i], vl[:, i].conj()
            deflated = np.real(ab - w[i] * np.outer(right, left) / (left @ right))
    w, width = w[keep], width[keep]
    if w.size == 0:
        return ScenePoles("stable", 0.0, 0.0, 0.0, 0.0, -math.inf, 0.0, n, free,
                          "no pole besides the free position (z = 1)")
    mod = np.abs(w)
    dom = int(np.argmax(mod))
    z = w[dom]
    rho, ang = float(mod[dom]), abs(float(np.angle(z)))
    gamma = math.log(rho) / sample_time if rho > 0 else -math.inf
    aside = "; the exact pole z = 1 of the free position (no wall stiffness) is set aside" if free else ""
    state: Literal["stable", "unstable", "marginal"]
    if np.any(mod - width > 1.0):
        j = int(np.argmax(np.where(mod - width > 1.0, mod, -np.inf)))
        state, reason = "unstable", (f"a closed-loop pole lies outside the unit circle: |z| = {mod[j]:.9g} "
                                     f"(± {width[j]:.1e}) at {abs(np.angle(w[j])) / sample_time:.6g} rad/s")
    elif np.all(mod + width < 1.0):
        state, reason = "stable", f"every closed-loop pole lies inside the unit circle: spectral radius {rho:.9g}"
    elif rho < 1.0 and _lyapunov_certificate(deflated):
        state, reason = "stable", (f"every closed-loop pole lies inside the unit circle: spectral radius {rho:.9g} "
                                   "(certified by a Lyapunov function, as some poles are too ill-conditioned "
                                   "for the rounding bound)")
    else:
        j = int(np.argmax(mod + width))
        state, reason = "marginal", (f"a closed-loop pole lies on the unit circle within rounding: |z| = "
                                     f"{mod[j]:.12g} ± {width[j]:.1e}; neither growth nor decay can be shown")
    return ScenePoles(state=state, spectral_radius=rho, dominant_modulus=rho, dominant_angle=ang,
                      dominant_frequency=ang / sample_time, growth_rate=gamma, rounding=float(width[dom]),
                      states=n, free_position_pole=free, reason=reason + aside)
