"""optim.stability.rendered_rigid's certified crossings as they ran before the one compiled call (issue 30, speed):
numpy builds the loop's polynomials, sine coefficients and bounds on every call and calls the module's compiled
isolation and refinement.  The twin the compiled driver ``_crossings`` is held to (tests/optim/stability/
test_rendered_rigid.py): the same crossings, values and directions, and the same answer (None) where it gives up.
Its convolutions and sums are written out in the kernel's order (numpy.convolve and numpy.sum add in another order
through BLAS and pairwise sums: the last bit of a bound's coefficient moves)."""

from __future__ import annotations

import math

import numpy as np

from models.discretize import RigidZOH
from models.velocity_filter import Rendering
from optim.stability.rendered_rigid import (
    _EPS,
    _NO_MODAL,
    LOOP_K,
    MAX_DEGREE,
    MAX_PIECES,
    _chebyshev_t,
    _clenshaw,
    _h,
    _isolate,
    _refine,
    _taylor_table,
    average_zero_angles,
    butter_form,
    v_zero_at_pi,
)

LOOP_B, LOOP_M = 1, 2


def _convolve(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """numpy.convolve(a, b), each output summed over a's index upwards from 0."""
    out = [0.0] * (a.size + b.size - 1)
    for i in range(a.size):
        for j in range(b.size):
            out[i + j] += float(a[i]) * float(b[j])
    return np.array(out)


def _sum(x: np.ndarray) -> float:
    total = 0.0
    for v in x:
        total += float(v)
    return total


def _plant_parts(plant: RigidZOH) -> tuple[np.ndarray, np.ndarray]:
    """(P₁ = [1, −p], Dg = w^{d+1}·M̃) of the module docstring."""
    omp, phi12, g0p, g0v, g1p, g1v, _ = plant.coefficients()
    p = 1.0 - omp
    if plant.f == 0.0:
        a, c = plant.f0_numerator()
        mt = np.array([a, a + c])
    else:
        mt = np.array([g0p, g1p - p * g0p + phi12 * g0v, phi12 * g1v - p * g1p])
    dg = np.concatenate([np.zeros(plant.d + 1), mt])
    return np.array([1.0, -p]), dg


def _polys(plant: RigidZOH, rendering: Rendering, loop: int, alpha: float, beta: float, mu: float,
           absolute: bool) -> tuple[np.ndarray, np.ndarray] | None:
    """(P, Q_s) of the loop: Q_s has Q's sign of Im (module docstring); with ``absolute`` every coefficient and every
    term taken positive (the sums that bound the rounding)."""
    p1, dg = _plant_parts(plant)
    r, d = np.asarray(rendering.velocity.r), np.asarray(rendering.velocity.d)
    omw = np.array([1.0, -1.0])
    if absolute:
        p1, dg, r, d, omw = np.abs(p1), np.abs(dg), np.abs(r), np.abs(d), np.abs(omw)
        alpha, beta, mu = abs(alpha), abs(beta), abs(mu)
    cv = _convolve
    if loop == LOOP_K:
        ctrl = beta * np.array([1.0, 0.0]) + mu * omw
        a1 = cv(cv(omw, p1), d)
        a2 = cv(cv(cv(dg, omw), ctrl), r)
        P = _add(a1, a2) if absolute else _add(-a1, -a2)
        return P, cv(dg, d)
    if butter_form(rendering.velocity.r):
        r_q, p_mul = np.array([0.0, r[0]]), np.ones(1)       # r₀(1 + w)² → r₀·w: the same sign of Im
    elif rendering.velocity.kind == "moving_average":
        r_q, p_mul = _average_q(len(r), absolute)
    elif _circle_zeros(rendering.velocity.r):
        return None                          # a zero of R on the circle: a pole of h there
    else:
        r_q, p_mul = r, np.ones(1)
    if loop == LOOP_B:
        a1 = cv(p1, d)
        a2 = mu * cv(cv(dg, omw), r)
        P = _add(a1, a2) if absolute else _add(-a1, -a2)
        return cv(P, p_mul), cv(dg, r_q)
    a1 = cv(p1, d)
    a3 = beta * cv(dg, r)
    if alpha == 0.0:
        P = _add(a1, a3) if absolute else _add(-a1, -a3)
        return cv(P, p_mul), cv(cv(dg, omw), r_q)
    a1 = cv(omw, a1)
    a2 = alpha * cv(dg, d)
    a3 = cv(omw, a3)
    P = _add(_add(a1, a2), a3) if absolute else _add(_add(-a1, -a2), -a3)
    return cv(P, p_mul), cv(cv(dg, np.array([0.0, 1.0]) if absolute else np.array([0.0, -1.0])), r_q)


def _average_q(n: int, absolute: bool) -> tuple[np.ndarray, np.ndarray]:
    """(Q's replacement for R, P's multiplier) of an n-sample moving average, R = (1 + w + … + w^{n−1})/n: for even
    n, R = (1 + w)·R'(w) with R' = (1 + w² + … + w^{n−2})/n, and P·(1 + w) over R'·(1 + w)² has Im of the same sign
    as P over R; (1 + w)² → w as for Butterworth.  The other zeros, e^{2πjk/n}, stay (their pieces are dropped)."""
    if n % 2:
        return np.full(n, 1.0 / n), np.ones(1)
    rp = np.zeros(n - 1)
    rp[::2] = 1.0 / n
    return np.concatenate([[0.0], rp]), np.ones(2)


def _add(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    if a.size < b.size:
        a, b = b, a
    out = a.copy()
    out[:b.size] += b
    return out


def _circle_zeros(r: tuple[float, ...]) -> bool:
    if len(r) < 2:
        return False
    return bool(np.any(np.abs(np.abs(np.roots(np.asarray(r[::-1]))) - 1.0) < 1e-6))


def _sine_coefficients(P: np.ndarray, Q: np.ndarray, absolute: bool) -> np.ndarray:
    """c_1..c_n: Im(P(w)·Q(w̄)) = Σ c_k sin kθ, w = e^{−jθ} (|c|'s bound with ``absolute``)."""
    r = _convolve(P, Q[::-1])          # r[i] is the coefficient of w^(i − (len(Q) − 1))
    zero = Q.size - 1
    n = max(zero, r.size - 1 - zero)
    pos = np.zeros(n + 1)
    neg = np.zeros(n + 1)
    pos[:r.size - zero] = r[zero:]
    neg[:zero + 1] = r[zero::-1]
    c = neg[1:] + pos[1:] if absolute else neg[1:] - pos[1:]
    return c


def _numbers(plant: RigidZOH) -> np.ndarray:
    omp, phi12, g0p, g0v, g1p, g1v, _ = plant.coefficients()
    a, c = plant.f0_numerator()
    nyq = plant.inverse_at_nyquist()
    return np.array([omp, a, c, phi12, g0p, g0v, g1p, g1v, float(plant.d), 1.0 if plant.f > 0.0 else 0.0,
                     0.0 if nyq is None else 1.0, 0.0 if nyq is None else nyq, 0.0])


def rigid_real_crossings_python(plant: RigidZOH, rendering: Rendering, loop: int, alpha: float, beta: float,
                         mu: float) -> list[tuple[float, float, int]] | None:
    """Every θ ∈ (0, π] where the loop's h is real (module docstring), as (θ, h(θ), outward) by θ: outward +2/−2 for
    a pair leaving/entering as the moving gain rises (the sign of d Im h/dθ), ±1 at θ = π; None where the
    certificate does not close (the caller scans).  The Nyquist point is listed when h(π) is finite and non-zero."""
    if plant.delta == 0.0:
        return None                                   # M̃ vanishes at w = −1: a pole of h at π
    alpha, beta, mu = float(alpha), float(beta), float(mu)   # one compiled signature
    polys = _polys(plant, rendering, loop, alpha, beta, mu, absolute=False)
    if polys is None:
        return None
    pabs = _polys(plant, rendering, loop, alpha, beta, mu, absolute=True)
    assert pabs is not None
    c = _sine_coefficients(*polys, absolute=False)
    cabs = _sine_coefficients(*pabs, absolute=True)
    a = _chebyshev_t(c)
    aabs = _chebyshev_t(cabs)
    n = a.size
    big = float(np.sum(aabs))
    if not (big > 0.0 and math.isfinite(big)) or n > MAX_DEGREE:
        return None
    dk = _taylor_table(a)
    dkabs = _taylor_table(aabs)          # every term positive: a bound of each |coefficient|
    err = 16.0 * (n + 8) ** 2 * _EPS * np.array([_sum(row) for row in dkabs])
    if n > 1:
        err[0] += _EPS * _sum(dkabs[1])       # x = cos θ rounded: |p'|·ε
    if not np.all(np.isfinite(err)):
        return None
    out = np.empty((n + 2, 5))
    count = _isolate(dk, err, out, MAX_PIECES)
    if count < 0:
        return None
    if loop != LOOP_K and rendering.velocity.kind == "moving_average":
        # a zero of R on the circle is a pole of h_B, h_M: its piece (the one root there is that pole) is dropped
        keep = []
        for i in range(count):
            t1, t2 = out[i, 0], out[i, 1]
            inside = [q for q in average_zero_angles(len(rendering.velocity.r)) if t1 <= q <= t2]
            if any(abs(q - t1) <= 1e-12 * q or abs(t2 - q) <= 1e-12 * q for q in inside):
                return None
            if not inside:
                keep.append(i)
        out = out[keep]
        count = len(keep)
    nums = _numbers(plant)
    r = np.asarray(rendering.velocity.r, dtype=float)
    dd = np.asarray(rendering.velocity.d, dtype=float)
    roots = np.empty((max(count, 1), 2))
    if count and not _refine(out, count, loop, nums, _NO_MODAL, r, dd, alpha, beta, mu, roots):
        return None
    # f'(θ) = −sin θ·p'(cos θ): Im h rises through the root where p' < 0
    found = [(float(roots[i, 0]), float(roots[i, 1]), 2 if out[i, 4] < 0.0 else -2) for i in range(count)]
    if loop != LOOP_K and v_zero_at_pi(rendering.velocity):
        v_pi = math.inf                # V(π) = 0 exactly (a Butterworth, an even moving average): a pole of h_B, h_M
    else:
        try:
            v_pi = complex(_h(math.pi, loop, nums, _NO_MODAL, r, dd, alpha, beta, mu)).real
        except ZeroDivisionError:
            v_pi = math.inf
    if math.isfinite(v_pi) and v_pi != 0.0:
        found.append((math.pi, v_pi, 1 if _clenshaw(a, -1.0) < 0.0 else -1))
    return [x for x in found if math.isfinite(x[1]) and abs(x[1]) < 1e250 and x[1] != 0.0]


