"""The delayed passivity bound's samples and its maximum's polish, compiled (numba; issue 20).

optim.stability.passivity's ``passivity_margin`` samples P(θ) = hk·s_d(θ) − B·cos((d+1)θ) on the part of its grid
the envelope cannot rule out, takes the three largest samples, and polishes each to P's local maximum by Newton on
P' = 0 inside its two grid steps.  Here are the two loops of that, the same operations in the same order as the
Python they replace (``_passivity_prefix``, whose numpy sin/cos are math's bit for bit on x86-64 with glibc, and
``_polish_max`` with ``_p_slopes_at``), so the same bits; the selection of the three largest samples stays numpy's
``argpartition`` (its order decides ties), in Python.  ``_p_slopes_at``'s numpy branch (d > 32 and (d + ½)θ < 1,
a BLAS dot whose summation order a loop does not reproduce) is not compiled: a bracket that reaches it is
polished in Python (``needs_python``).  tests/optim/stability/test_passivity_kernel.py holds both kernels to their
Python twins bit for bit on random walls (d 1-400, B up to 100× the physical damping, K up to 10× passive).
"""

from __future__ import annotations

import math

import numpy as np

from optim.stability.compiled import kernel

__all__ = ["prefix_samples", "polish_max", "best_of_rows", "needs_python", "compile_kernels"]

_EPS = 2.220446049250313e-16
#: _p_slopes_at takes the closed form's derivatives above this many delay samples (passivity._SUM_TERMS_MIN)
_SUM_TERMS_MIN = 4
#: above this many delay samples and below (d + ½)θ = 1 _p_slopes_at sums in numpy (passivity._p_slopes)
_NUMPY_SUM_MIN = 32


@kernel
def needs_python(d, a):
    """Whether polishing a bracket starting at θ = ``a`` reaches _p_slopes_at's numpy branch."""
    return d > _NUMPY_SUM_MIN and (d + 0.5) * a < 1.0


@kernel
def _fill(theta, vals, lo, hi, n, step, d, hk, damping):
    """passivity._passivity_prefix's ``samples(lo, hi)`` into theta[lo:hi], vals[lo:hi]."""
    big_n, e = d + 0.5, float(d + 1)
    for i in range(lo, hi):
        t = i * step
        if i == n - 1:
            t = math.pi                                    # as linspace sets its end point
        theta[i] = t
        s = 2 * d + 1.0 if i == 0 else math.sin(big_n * t) / math.sin(t / 2)
        vals[i] = hk * s - damping * math.cos(e * t)


@kernel
def prefix_samples(d, n, hk, damping):
    """passivity._passivity_prefix: (θ, P(θ)) on the part of the n-sample grid where P may reach its maximum, and
    P(π)."""
    step = math.pi / (n - 1)
    v_pi = hk * (math.sin((d + 0.5) * math.pi) / math.sin(math.pi / 2)) - damping * math.cos((d + 1) * math.pi)
    first = min(n, 3 * 64 + 3)
    theta = np.empty(n)
    vals = np.empty(n)
    _fill(theta, vals, 0, first, n, step, d, hk, damping)
    v_low, c = max(vals[:first].max(), v_pi), hk + damping
    keep = n
    if v_low > c:
        keep = min(n, int(2.0 * math.atan(hk / math.sqrt((v_low - c) * (v_low + c))) / step) + 3)
    if keep > first:
        _fill(theta, vals, first, keep, n, step, d, hk, damping)
    else:
        keep = first
    return theta[:keep], vals[:keep], v_pi


@kernel
def _slopes(t, d, hk, damping):
    """passivity._p_slopes_at without its numpy branch (the caller keeps away from it: ``needs_python``)."""
    if d > _SUM_TERMS_MIN:
        big_n = d + 0.5
        u = big_n * t
        if u >= 1.0:
            sv, cv = math.sin(0.5 * t), math.cos(0.5 * t)
            su = math.sin(u)
            s = su / sv
            ds = (big_n * math.cos(u) - 0.5 * s * cv) / sv
            dds = (-big_n * big_n * su - ds * cv + 0.25 * s * sv) / sv
            e = d + 1.0
            return hk * ds + damping * e * math.sin(e * t), hk * dds + damping * e * e * math.cos(e * t)
    ds = dds = 0.0
    for k in range(1, d + 1):
        ds += k * math.sin(k * t)
        dds += k * k * math.cos(k * t)
    e = d + 1.0
    return hk * (-2.0 * ds) + damping * e * math.sin(e * t), hk * (-2.0 * dds) + damping * e * e * math.cos(e * t)


@kernel
def polish_max(d, hk, damping, a, b, t):
    """passivity._polish_max: the local maximum of P inside [a, b] from ``t`` (nan when the bracket holds none)."""
    fa, ca = _slopes(a, d, hk, damping)
    fb, cb = _slopes(b, d, hk, damping)
    if not ((ca > 0 if a == 0.0 else fa > 0) and (cb > 0 if b == math.pi else fb < 0)):
        return math.nan
    eps4 = 4 * _EPS
    for _ in range(100):
        f, fp = _slopes(t, d, hk, damping)
        if f == 0.0:
            break
        if f > 0:
            a = t
        else:
            b = t
        if fp < 0:
            step = f / fp
            if abs(step) <= eps4 * abs(t):
                break
            newton = t - step
            t = newton if a < newton < b else 0.5 * (a + b)
        else:
            t = 0.5 * (a + b)
        if b - a <= eps4 * b:
            break
    return t


@kernel
def best_of_rows(d, hk, damping, grid, vals, top, v_pi):
    """passivity_margin's rows: each of the ``top`` samples polished to the local maximum inside its two grid
    steps (skipped when a maximum already found lies in that bracket; started at the vertex of the parabola through
    the three samples, the bracket's middle at an end), then the largest of the top samples, the maxima and P(π),
    the first of equal ones.  Returns (sup P, its θ, True), or (nan, nan, False) without deciding anything when a
    bracket reaches _p_slopes_at's numpy branch (``needs_python``: the caller runs the rows in Python)."""
    last = grid.size - 1
    n_top = top.size
    cand_t = np.empty(2 * n_top + 1)
    cand_v = np.empty(2 * n_top + 1)
    for row in range(n_top):
        cand_t[row] = grid[top[row]]
        cand_v[row] = vals[top[row]]
    n = n_top
    for row in range(n_top):
        i = top[row]
        i_lo, i_hi = max(i - 1, 0), min(i + 1, last)
        lo, hi = grid[i_lo], grid[i_hi]
        seen = False
        for r in range(n_top, n):
            if lo < cand_t[r] < hi:
                seen = True
        if seen:
            continue
        v0, v1, v2 = vals[i_lo], vals[i], vals[i_hi]
        curv = v0 - 2 * v1 + v2
        vertex = cand_t[row] + 0.5 * (hi - lo) / 2 * (v0 - v2) / curv if curv < 0 else math.nan
        inside = i_lo < i < i_hi and curv < 0 and lo < vertex < hi
        if needs_python(d, lo):
            return math.nan, math.nan, False
        t = polish_max(d, hk, damping, lo, hi, vertex if inside else 0.5 * (lo + hi))
        if math.isnan(t):
            continue
        half = math.sin(t / 2)
        s_t = math.sin((d + 0.5) * t) / half if half != 0.0 else 2 * d + 1.0
        cand_t[n] = t
        cand_v[n] = hk * s_t - damping * math.cos((d + 1) * t)
        n += 1
    cand_t[n] = math.pi
    cand_v[n] = v_pi
    j = 0
    for c in range(1, n + 1):
        if cand_v[c] > cand_v[j]:
            j = c
    return cand_v[j], cand_t[j], True


def compile_kernels() -> None:
    """Compile the kernels now (or load them from numba's cache): see optim.stability.rigid_kernel."""
    grid, vals, v_pi = prefix_samples(3, 64 * 4 + 257, 0.5, 0.1)
    polish_max(3, 0.5, 0.1, 0.1, 0.2, 0.15)
    best_of_rows(3, 0.5, 0.1, grid, vals, np.argpartition(-vals, 2)[:3], v_pi)
