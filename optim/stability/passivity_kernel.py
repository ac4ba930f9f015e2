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

__all__ = ["prefix_samples", "polish_max", "best_of_rows", "needs_python", "sup_bound", "p_value", "SUP_TOL",
           "compile_kernels"]

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


#: the bound's closing tolerance, relative to P's scale hk·(2d+1) + |B| (the required damping is within this, plus
#: twice the rounding bound ρ, above the true sup: ``sup_bound``)
SUP_TOL = 1e-13
#: max |ω(x)|/6 over [c − r, c + r] for ω = (x − a)(x − c)(x − b), c the middle: r³/(9√3), with room for a c
#: that is the middle only to rounding
_CUBIC = 1.0001 / (9.0 * math.sqrt(3.0))
#: intervals waiting in sup_bound's depth-first search (a full stack accepts the interval's bound as it is: still
#: an upper bound, only a looser one, and the error bound says so)
_STACK = 2048
#: evaluations of P the bisection may spend (then, as with a full stack, the pieces' bounds are accepted as they are)
_MAX_EVALS = 20000


@kernel
def p_value(t, d, hk, damping):
    """P(θ) = hk·s_d(θ) − B·cos((d+1)θ) by _fill's operations (2d + 1 at θ = 0)."""
    s = 2 * d + 1.0 if t == 0.0 else math.sin((d + 0.5) * t) / math.sin(t / 2)
    return hk * s - damping * math.cos(float(d + 1) * t)


@kernel
def sup_bound(d, n, hk, damping, grid, vals, v_best, t_best, tol_rel):
    """A proven upper bound of sup over θ ∈ [0, π] of P(θ) = hk·s_d(θ) − B·cos((d+1)θ), closed to a tolerance.

    ``grid``, ``vals``: the first samples of the n-sample grid θ_i = i·π/(n − 1) (prefix_samples; the rest are
    computed here as needed); ``v_best`` at ``t_best``: the largest value found so far (P there, as computed).
    Returns (U, v, t, err): U ≥ sup P; v = P(t), the largest value met (as computed); err = U − (v − ρ) ≥ U − sup P.

    Nothing between samples is taken from the samples' size alone.  Each grid interval [a, b] is bounded by
      * the envelope: P = hk·cot(θ/2)·sin u − (hk + B)·cos u (u = (d+1)θ) ≤ E(θ) = √(hk²cot²(θ/2) + (hk + B)²),
        which falls with θ: P ≤ E(a) on [a, b] and on every later interval (the scan stops there);
      * the second derivative: |P''| ≤ M2 = hk·2Σk² + |B|·(d+1)², so P ≤ max(P(a), P(b)) + M2·(b − a)²/8.
    An interval whose bound exceeds the best value by more than the tolerance is bisected; each piece is bounded by
    the quadratic through P(a), P(c), P(b) (c its middle) plus the interpolation error M3·r³/(9√3)
    (|P'''| ≤ M3 = hk·2Σk³ + |B|·(d+1)³, r = (b − a)/2), and the quadratic's vertex is evaluated as a candidate,
    until every piece's bound lies below the best value or within tol_rel·(hk·(2d+1) + |B|) of it.

    Rounding: every computed P(θ) is within ρ = ε·(24·(d + ½)·hk + (4(d+1) + 4)·|B|) of the true P at that θ
    (sin and cos of (d + ½)θ and (d+1)θ carry the product's rounding ε·(d+1)·θ as a phase error, the rest a few
    ε of hk·|s| ≤ hk·(2d+1): first-order bounds, with room).  Each bound adds ρ (the quadratic 2ρ, its Lebesgue
    constant being 1.25, and 32ε of the values for its own arithmetic), so U ≥ sup P, and
    U − sup P ≤ err ≤ tol_rel·scale + 2ρ wherever the bisection closed (err says what was reached)."""
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


def compile_kernels() -> None:
    """Compile the kernels now (or load them from numba's cache): see optim.stability.rigid_kernel."""
    grid, vals, v_pi = prefix_samples(3, 64 * 4 + 257, 0.5, 0.1)
    polish_max(3, 0.5, 0.1, 0.1, 0.2, 0.15)
    v, t, _ = best_of_rows(3, 0.5, 0.1, grid, vals, np.argpartition(-vals, 2)[:3], v_pi)
    sup_bound(3, 64 * 4 + 257, 0.5, 0.1, grid, vals, v, t, SUP_TOL)
