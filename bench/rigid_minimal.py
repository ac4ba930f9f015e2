"""A minimal vectorised K_cr and B_max of many rigid devices: the floor issue 32 holds zwidth's batch to.

Written from the physics, not from zwidth's code (only numpy): the plant 1/(ms² + bs) under ZOH and a delay
t_d = (d + f)·T sampled exactly (the state-space step with the input's two pieces, φ₁/φ₂ by their series below
0.5), the loop's inverse response W(θ) = −1/G(e^{jθ}), and

* K_cr(B): the first phase crossover of H = W + β(e^{−jθ} − 1) (Im H changes sign, Re H > 0) or the Nyquist
  point, the smaller; 0 when B ≥ B_max or there is no damping;
* B_max: the first crossover of the damper-only loop D = W/(1 − e^{−jθ}).

Each found on one geometric grid of GRID points per device (every device's row at once), its bracket then
refined by a vectorised Illinois false position to full double precision.  No validation, no fallback, no error
estimate: what a lab would write in an afternoon for random rigid devices it trusts.  bench.bench_core times it
beside optim.robust.batch.rigid_critical_stiffness on the same arrays and counts the rows that differ by more than
1e-12 relative (they must be none).  Trusting "the first crossover binds" is what zwidth proves
(optim.stability.fast_rigid); this file does not prove it, the comparison checks it.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["minimal_rigid_batch", "GRID"]

#: grid points per device (geometric from far below the first crossover to π/2, then 8 evenly to π)
GRID = 16
_EPS = np.finfo(float).eps


def _phi(x: np.ndarray, k: int) -> np.ndarray:
    """φ_k(x) = Σ_{n≥0} (−x)^n/(n + k)!, k = 1: (1 − e^{−x})/x, k = 2: (x − 1 + e^{−x})/x²."""
    small = x < 0.5
    xs = np.where(small, x, 0.0)
    acc = np.zeros_like(x)
    for n in range(20, -1, -1):
        acc = acc * (-xs) + 1.0 / math.factorial(n + k)
    with np.errstate(divide="ignore", invalid="ignore"):
        big = -np.expm1(-x) / x if k == 1 else (x + np.expm1(-x)) / (x * x)
    return np.where(small, acc, big)


class _Plant:
    def __init__(self, delta: np.ndarray, ds: np.ndarray):
        near = np.round(ds)
        snap = np.abs(ds - near) <= 64 * _EPS * np.maximum(1.0, ds)
        self.d = np.where(snap, near, np.floor(ds))
        f = np.where(snap, 0.0, ds - self.d)
        s = 1.0 - f
        omp = self.omp = -np.expm1(-delta)                    # 1 − p, p = e^{−δ}
        a12 = _phi(delta, 1)
        g0p, g0v = s * s * _phi(delta * s, 2), s * _phi(delta * s, 1)
        g1p = f * f * _phi(delta * f, 2) + s * _phi(delta * s, 1) * f * _phi(delta * f, 1)
        g1v = np.exp(-delta * s) * f * _phi(delta * f, 1)
        # z·N(z) = A z² + B z + C with N = (z − p)(Γ0p + Γ1p/z) + Φ₁₂(Γ0v + Γ1v/z)
        p = 1.0 - omp
        a, b, c = g0p, g1p - p * g0p + a12 * g0v, a12 * g1v - p * g1p
        self.apc, self.amc, self.b = a + c, a - c, b
        # W at the Nyquist point z = −1 (real): 2(1 + p)(−1)^d/(A + C − B)
        self.w_pi = 2.0 * (2.0 - omp) * np.where(self.d % 2 == 1, -1.0, 1.0) / (a + c - b)

    def polar(self, t: np.ndarray, r):
        """(R, ψ) of W = −1/G = R·e^{jψ} at θ = t for rows r, ψ continuous from −π/2 at θ → 0⁺:
        W = −(z − 1)(z − p)z^d/N, arg(z − 1) = (π + θ)/2, and z·N = e^{jθ}((A + C)cos θ + B + j(A − C) sin θ)."""
        sh, st, ct = np.sin(0.5 * t), np.sin(t), np.cos(t)
        re_p = self.omp[r] - 2.0 * sh * sh                     # Re(z − p)
        re_n, im_n = self.apc[r] * ct + self.b[r], self.amc[r] * st
        psi = (-0.5 * math.pi + 0.5 * t + np.arctan2(st, re_p) + self.d[r] * t - np.arctan2(im_n, re_n))
        mag = 2.0 * sh * np.sqrt(re_p * re_p + st * st) / np.sqrt(re_n * re_n + im_n * im_n)
        return mag, psi


def _first_root(fun, lo: np.ndarray, rows: np.ndarray):
    """(has, θ) of the first root of fun(θ, rows) (negative at θ → 0⁺) on a grid (geometric from lo to π/2, then linear to π(1 − 1e-7): at π itself H is real and the sign of Im H is rounding), refined by
    the secant method kept inside the bracket (bisection where it leaves it); ``has`` False where fun stays
    negative up to π."""
    u = np.linspace(0.0, 1.0, GRID - 8)
    grid = np.sort(np.concatenate([lo[:, None] * (0.5 * math.pi / lo[:, None]) ** u[None, :],
                                   np.broadcast_to(np.linspace(0.5625, 1.0 - 1e-7, 8) * math.pi, (lo.size, 8))], axis=1), axis=1)
    v = fun(grid, rows[:, None])
    pos = v >= 0.0
    has = pos.any(axis=1)
    k = np.argmax(pos, axis=1)
    r = np.flatnonzero(has)
    theta = np.full(rows.size, np.nan)
    j = np.maximum(k[r] - 1, 0)
    a, b, fa, fb = grid[r, j], grid[r, k[r]], v[r, j], v[r, k[r]]
    x0, y0, x1, y1 = a.copy(), fa.copy(), b.copy(), fb.copy()
    out = b.copy()
    act = np.flatnonzero(fb != 0.0)
    for _ in range(100):
        if act.size == 0:
            break
        aa, bb = a[act], b[act]
        step = y1[act] * (x1[act] - x0[act]) / (y1[act] - y0[act])
        x = x1[act] - step
        sec = (x > aa) & (x < bb)
        x = np.where(sec, x, 0.5 * (aa + bb))
        y = fun(x, rows[r[act]])
        left = y < 0.0
        a[act], b[act] = np.where(left, x, aa), np.where(left, bb, x)
        x0[act], y0[act], x1[act], y1[act] = x1[act], y1[act], x, y
        done = (y == 0.0) | (b[act] - a[act] <= 4.0 * _EPS * b[act]) | (sec & (np.abs(step) <= 2.0 * _EPS * x))
        out[act[done]] = x[done]
        act = act[~done]
    theta[r] = out
    return has, theta


def minimal_rigid_batch(mass: np.ndarray, damping: np.ndarray, sample_time: np.ndarray, delay: np.ndarray,
                        virtual_damping: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(K_cr [N/m], B_max [N·s/m]) of every rigid device (SI arrays)."""
    m, b, t, td, bv = (np.asarray(x, float) for x in (mass, damping, sample_time, delay, virtual_damping))
    n = m.size
    delta, beta, ds = b * t / m, bv * t / m, td / t
    P = _Plant(delta, ds)
    rows = np.arange(n)
    lo = 1e-2 * np.minimum(np.sqrt((delta + beta) / (ds + 1.0)), 1.0 / (ds + 1.0))
    with np.errstate(all="ignore"):
        def damper(x, r):                       # arg D = ψ + θ/2 − π/2, D = W/(1 − e^{−jθ})
            return P.polar(x, r)[1] + 0.5 * x - 0.5 * math.pi

        has, tb = _first_root(damper, lo, rows)
        bmax = np.where(P.w_pi > 0.0, 0.5 * P.w_pi, np.inf)         # the crossover at π, else none
        bmax[has] = np.minimum(bmax[has], P.polar(tb[has], rows[has])[0] / (2.0 * np.sin(0.5 * tb[has])))

        def k_loop(x, r):                       # Im H = R sin ψ − β sin θ = 0: ψ = arcsin(β sin θ / R)
            mag, psi = P.polar(x, r)
            g = np.minimum(beta[r] * np.sin(x) / mag, 1.0)
            return psi - np.arcsin(g)

        has, tk = _first_root(k_loop, lo, rows)
        h_pi = P.w_pi - 2.0 * beta
        alpha = np.where(h_pi > 0.0, h_pi, np.inf)
        mag, psi = P.polar(tk[has], rows[has])
        alpha[has] = np.minimum(alpha[has], mag * np.cos(psi) + beta[has] * (np.cos(tk[has]) - 1.0))   # Re H there
    kcr = alpha * m / t**2
    bmax = bmax * m / t
    dead = (b + bv <= 0.0) | ((bv > 0.0) & (bv >= bmax))
    return np.where(dead, 0.0, kcr), bmax
