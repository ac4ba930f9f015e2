"""optim.stability.passivity's sampling of P as it ran in Python (numpy): the twin that
optim.stability.passivity_kernel.prefix_samples is held to bit for bit (test_passivity_kernel.py), and the proven
bound's twin (``sup_bound``, ``p_value``: passivity_kernel's, written out again).  The polish's twin is
passivity._polish_max itself (still run where its numpy branch is needed)."""

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


#: passivity_kernel's constants, copied (the twin is not read from the module it checks)
_EPS = 2.220446049250313e-16
_CUBIC = 1.0001 / (9.0 * math.sqrt(3.0))
_STACK = 2048
#: evaluations of P the bisection may spend (then, as with a full stack, the pieces' bounds are accepted as they are)
_MAX_EVALS = 20000


def p_value(t: float, d: int, hk: float, damping: float) -> float:
    """P(θ) = hk·s_d(θ) − B·cos((d+1)θ) by _fill's operations (2d + 1 at θ = 0)."""
    s = 2 * d + 1.0 if t == 0.0 else math.sin((d + 0.5) * t) / math.sin(t / 2)
    return hk * s - damping * math.cos(float(d + 1) * t)


def sup_bound(d: int, n: int, hk: float, damping: float, grid: np.ndarray, vals: np.ndarray, v_best: float,
              t_best: float, tol_rel: float) -> tuple[float, float, float, float]:
    """passivity_kernel.sup_bound in plain Python floats, operation for operation (its proof is there)."""
    ah, ab = abs(hk), abs(damping)
    e = float(d + 1)
    big_n = d + 0.5
    scale = ah * (2 * d + 1.0) + ab
    rho = 1.01 * _EPS * (24.0 * big_n * ah + (4.0 * e + 4.0) * ab)
    m2 = (ah * d * (d + 1.0) * (2 * d + 1.0) / 3.0 + ab * e * e) * (1.0 + 8 * _EPS)
    m3 = (ah * (d * (d + 1.0)) ** 2 / 2.0 + ab * e * e * e) * (1.0 + 8 * _EPS)
    tol = tol_rel * scale
    c_env = ah + ab
    v_lo, t_lo = v_best, t_best
    upper = v_best + rho
    keep = grid.size
    step = math.pi / (n - 1)
    st = np.empty((_STACK, 6))
    evals = 0
    fb = vals[0]
    for i in range(n - 1):
        a = grid[i] if i < keep else i * step
        b = grid[i + 1] if i + 1 < keep else (math.pi if i + 1 == n - 1 else (i + 1) * step)
        fa = fb
        fb = vals[i + 1] if i + 1 < keep else p_value(b, d, hk, damping)
        if fb > v_lo:
            v_lo, t_lo = fb, b
        env = math.inf
        if a > 0.0:
            cot = ah / math.tan(0.5 * a)
            env = math.sqrt(cot * cot + c_env * c_env) * (1.0 + 8 * _EPS)
            if env <= v_lo + rho:
                break                     # E falls with θ: no later interval can exceed the best value either
        h = b - a
        ub = min(max(fa, fb) + m2 * h * h * 0.125 + rho, env)
        if ub <= v_lo + rho:
            continue
        if ub - rho <= v_lo + tol:
            upper = max(upper, ub)
            continue
        c = 0.5 * (a + b)
        fc = p_value(c, d, hk, damping)
        if fc > v_lo:
            v_lo, t_lo = fc, c
        st[0, 0], st[0, 1], st[0, 2], st[0, 3], st[0, 4], st[0, 5] = a, c, b, fa, fc, fb
        top = 1
        while top > 0:
            top -= 1
            x0, x1, x2, f0, f1, f2 = st[top, 0], st[top, 1], st[top, 2], st[top, 3], st[top, 4], st[top, 5]
            ra, rb = x1 - x0, x2 - x1
            r = 0.5 * (x2 - x0)
            d1 = (f1 - f0) / ra
            k2 = ((f2 - f1) / rb - d1) / (ra + rb)
            g = d1 + k2 * ra
            qmax = max(f0, f2)
            tv = math.nan
            if k2 < 0.0:
                u = -g / (2.0 * k2)
                if -ra < u < rb:
                    qmax = max(qmax, f1 - g * g / (4.0 * k2))
                    tv = x1 + u
            noise = 2.0 * rho + 32.0 * _EPS * max(abs(f0), abs(f1), abs(f2))
            ub = qmax + _CUBIC * m3 * r * r * r + noise
            if ub <= v_lo + rho:
                continue
            if ub - noise > v_lo + tol and not math.isnan(tv):
                fv = p_value(tv, d, hk, damping)
                evals += 1
                if fv > v_lo:
                    v_lo, t_lo = fv, tv
                if ub <= v_lo + rho:
                    continue
            if ub - noise <= v_lo + tol or top + 2 > _STACK or evals > _MAX_EVALS or r <= 4 * _EPS * x2:
                upper = max(upper, ub)
                continue
            m0, m1 = 0.5 * (x0 + x1), 0.5 * (x1 + x2)
            g0, g1 = p_value(m0, d, hk, damping), p_value(m1, d, hk, damping)
            evals += 2
            if g0 > v_lo:
                v_lo, t_lo = g0, m0
            if g1 > v_lo:
                v_lo, t_lo = g1, m1
            st[top, 0], st[top, 1], st[top, 2], st[top, 3], st[top, 4], st[top, 5] = x1, m1, x2, f1, g1, f2
            st[top + 1, 0], st[top + 1, 1], st[top + 1, 2] = x0, m0, x1
            st[top + 1, 3], st[top + 1, 4], st[top + 1, 5] = f0, g0, f1
            top += 2
    upper = max(upper, v_lo + rho)
    return upper, v_lo, t_lo, upper - (v_lo - rho)
