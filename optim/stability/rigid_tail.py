"""Proof that a rigid loop has no K > 0 crossover on [θ_r, π) (the tail past the rising phase), without a scan.

Notation of optim.stability.fast_rigid.  A K > 0 crossover needs F̃(θ) = ψ − asin(min(g, 1)) ≡ 0 (mod 2π)
(there with R > β).  F̃ splits into monotone pieces:

    F̃ = I(θ) − Σ_i arg(z + q_i),   I(θ) = (d + m + ½)θ + arg(z − p) − π/2 − asin(min(g, 1)),

I rises (arg(z − p) rises for 0 < p < 1, g = β cos(θ/2)/R falls), arg(z + q) rises for a zero inside the unit
circle (q < 1) and, for one outside (q > 1), rises up to θ = acos(−1/q) and falls after.  So on [a, b]

    I(a) − Σ max_[a,b] arg(z + q_i)  ≤  F̃  ≤  I(b) − Σ min_[a,b] arg(z + q_i),

and an interval whose bounds hold no multiple of 2π holds no crossover.  Bisection tightens the bounds.

At θ = π every arg is 0 or π and F̃(π) = (half_pis_at_pi − 1)·π/2 exactly; when that is a multiple of 2π (the
Nyquist point is a crossover itself) no value bound can clear an interval ending at π, so [c, π] is cleared by
the sign of F̃' instead: F̃ running monotonically into its level at π never meets it before.  On [c, π]
(c ≥ π/2), with Re z/(z − p) falling, Re z/(z + q) rising for q < 1 and falling for q > 1 (each its own
derivative of arg):

    F̃' ≤ d + m + ½ + Re z/(z−p)|_c − Σ_{q<1} Re z/(z+q)|_c + Σ_{q>1} 1/(q − 1) + A,
    F̃' ≥ d + m + ½ + 1/(1 + p) − Σ_{q<1} 1/(1 − q) − Σ_{q>1} Re z/(z+q)|_c,

A bounding the asin term's derivative g·(½ tan(θ/2) + R'/R)/√(1 − g²) ≥ 0 (g·½tan(θ/2) = β sin(θ/2)/(2R) ≤
β/(2R(c)); R'/R ≤ p + Σ √q/(2|1 − q|); g ≤ g(c) < 1).

Where nothing closes (a crossover really lies in the tail, or the bounds stay loose) the answer is None and the
caller scans, as before.  Held against the scan on random devices by tests/optim/stability/test_rigid_tail.py.

Compiled (numba, optim.stability.compiled) on the loop's numbers of optim.stability.rigid_kernel; a point is
(I(θ), arg(z + q₁), arg(z + q₂)).  Its Python form, the exact rung's before issue 20's kernels, is the twin in
tests/optim/stability/rigid_python.py, whose verdicts test_rigid_kernel.py holds equal on random devices.
"""

from __future__ import annotations

import math

import numpy as np

from optim.stability.compiled import kernel
from optim.stability.fast_rigid import RigidLoop
from optim.stability.rigid_kernel import AT_LEAD, AT_NZ, AT_OMP, AT_OMQ1, AT_OMQ2, AT_P, AT_Q1, AT_Q2, AT_SLOPE

__all__ = ["tail_is_clear"]

_TWO_PI = 2.0 * math.pi
#: interval evaluations before giving up (the scan decides then)
_MAX_INTERVALS = 64
#: halvings of π − θ_r searched for the end interval [c, π] on which F̃ is monotone
_MAX_END_HALVINGS = 60


def tail_is_clear(L: RigidLoop, beta: float) -> bool:
    """True when provably no K > 0 crossover lies in [θ_r, π) (the Nyquist point itself is the caller's)."""
    return _tail_is_clear(L.numbers, beta, L.theta_r, L.half_pis_at_pi)


@kernel
def _tail_point(v, beta, t):
    """rigid_tail._point: (I(θ), arg(z + q₁), arg(z + q₂) or 0) at θ = t < π."""
    sh, ch = math.sin(0.5 * t), math.cos(0.5 * t)
    st = 2.0 * sh * ch
    re_p = v[AT_OMP] - 2.0 * sh * sh
    den_p = re_p * re_p + st * st
    mag = math.sqrt(den_p) / v[AT_LEAD]
    re_q = 2.0 * ch * ch - v[AT_OMQ1]
    arg1 = math.atan2(st, re_q)
    mag /= math.sqrt(re_q * re_q + st * st)
    arg2 = 0.0
    if v[AT_NZ] == 2.0:
        re_q = 2.0 * ch * ch - v[AT_OMQ2]
        arg2 = math.atan2(st, re_q)
        mag /= math.sqrt(re_q * re_q + st * st)
    g = beta * ch / mag if beta > 0.0 else 0.0
    inc = v[AT_SLOPE] * t - math.atan2(re_p, st) - (math.asin(g) if g < 1.0 else 0.5 * math.pi)
    return inc, arg1, arg2


@kernel
def _interval_clear(v, a, b, inc_a, xa1, xa2, inc_b, xb1, xb2):
    """rigid_tail._interval_clear and _clear: no multiple of 2π between the bounds of F̃ on [a, b]."""
    lo, hi = inc_a, inc_b
    for i in range(int(v[AT_NZ])):
        q = v[AT_Q1 + 2 * i]
        xa, xb = (xa1, xb1) if i == 0 else (xa2, xb2)
        if q < 1.0:
            lo -= xb
            hi -= xa
        else:
            tm = math.acos(-1.0 / q)
            top = math.asin(1.0 / q) if a <= tm <= b else max(xa, xb)
            lo -= top
            hi -= min(xa, xb)
    pad = 1e-11 * (1.0 + abs(lo) + abs(hi))
    lo, hi = lo - pad, hi + pad
    return math.floor(hi / _TWO_PI) * _TWO_PI < lo


@kernel
def _slope_sign_on_end(v, beta, c):
    """rigid_tail._slope_sign_on_end: +1 / −1 when F̃' > 0 / < 0 on all of [c, π], else 0."""
    sh, ch = math.sin(0.5 * c), math.cos(0.5 * c)
    st = 2.0 * sh * ch
    omp, p = v[AT_OMP], v[AT_P]
    re_p = omp - 2.0 * sh * sh
    den_p = re_p * re_p + st * st
    up = v[AT_SLOPE] + (omp + 2.0 * p * sh * sh) / den_p
    low = v[AT_SLOPE] + 1.0 / (1.0 + p)
    mag = math.sqrt(den_p) / v[AT_LEAD]
    dlr = p
    for i in range(int(v[AT_NZ])):
        q, omq = v[AT_Q1 + 2 * i], v[AT_OMQ1 + 2 * i]
        re_q = 2.0 * ch * ch - omq
        den_q = re_q * re_q + st * st
        rq = (omq + 2.0 * q * ch * ch) / den_q
        mag /= math.sqrt(den_q)
        if q < 1.0:
            up -= rq
            low -= 1.0 / omq
        else:
            up += 1.0 / (q - 1.0)
            low -= rq
        dlr += math.sqrt(q) / (2.0 * abs(omq))
    if beta > 0.0:
        g = beta * ch / mag
        if not g < 1.0:
            return 0
        up += (0.5 * beta / mag + g * dlr) / math.sqrt((1.0 - g) * (1.0 + g))
    if up < 0.0:
        return -1
    if low > 0.0:
        return 1
    return 0


@kernel
def _tail_is_clear(v, beta, theta_r, half_pis_at_pi):
    """``tail_is_clear`` on the loop's numbers."""
    a = theta_r
    nz = int(v[AT_NZ])
    has_pole = v[AT_OMQ1] == 0.0 or (nz == 2 and v[AT_OMQ2] == 0.0)
    if not (math.pi / 2 <= a < math.pi) or has_pole:
        return a >= math.pi
    # rigid_tail._at_pi: arg(z + q) = π inside the unit circle, 0 outside
    e1 = math.pi if v[AT_Q1] < 1.0 else 0.0
    e2 = (math.pi if v[AT_Q2] < 1.0 else 0.0) if nz == 2 else 0.0
    end_inc = (half_pis_at_pi - 1) * 0.5 * math.pi + (0.0 + e1 + e2 if nz == 2 else 0.0 + e1)
    b = math.pi
    if ((half_pis_at_pi - 1) // 2) % 2 == 0:
        level = end_inc - (0.0 + e1 + e2 if nz == 2 else 0.0 + e1)
        eps = math.pi - a
        sign = 0
        c = math.pi
        for _ in range(_MAX_END_HALVINGS):
            c = math.pi - eps
            sign = _slope_sign_on_end(v, beta, c)
            if sign:
                break
            eps *= 0.5
        if not sign:
            return False
        pc_inc, pc1, pc2 = _tail_point(v, beta, c)
        fc = pc_inc - (0.0 + pc1 + pc2 if nz == 2 else 0.0 + pc1)
        if not (level < fc < level + _TWO_PI if sign < 0 else level - _TWO_PI < fc < level):
            return False
        if abs(fc - level) <= 1e-11 * (1.0 + abs(level)):
            return False
        if c <= a:
            return True
        b, end_inc, e1, e2 = c, pc_inc, pc1, pc2
    size = 2 * _MAX_INTERVALS + 2
    st_lo, st_hi = np.empty(size), np.empty(size)
    st_pl, st_ph = np.empty((size, 3)), np.empty((size, 3))
    p_inc, p1, p2 = _tail_point(v, beta, a)
    st_lo[0], st_hi[0] = a, b
    st_pl[0, 0], st_pl[0, 1], st_pl[0, 2] = p_inc, p1, p2
    st_ph[0, 0], st_ph[0, 1], st_ph[0, 2] = end_inc, e1, e2
    top = 1
    budget = _MAX_INTERVALS
    while top > 0:
        top -= 1
        lo, hi = st_lo[top], st_hi[top]
        l0, l1, l2 = st_pl[top, 0], st_pl[top, 1], st_pl[top, 2]
        h0, h1, h2 = st_ph[top, 0], st_ph[top, 1], st_ph[top, 2]
        if _interval_clear(v, lo, hi, l0, l1, l2, h0, h1, h2):
            continue
        budget -= 1
        if budget <= 0 or hi - lo <= 1e-12 * hi:
            return False
        mid = 0.5 * (lo + hi)
        m0, m1, m2 = _tail_point(v, beta, mid)
        st_lo[top], st_hi[top] = mid, hi                 # (mid, hi) pushed first, (lo, mid) popped next
        st_pl[top, 0], st_pl[top, 1], st_pl[top, 2] = m0, m1, m2
        st_ph[top, 0], st_ph[top, 1], st_ph[top, 2] = h0, h1, h2
        st_lo[top + 1], st_hi[top + 1] = lo, mid
        st_pl[top + 1, 0], st_pl[top + 1, 1], st_pl[top + 1, 2] = l0, l1, l2
        st_ph[top + 1, 0], st_ph[top + 1, 1], st_ph[top + 1, 2] = m0, m1, m2
        top += 2
    return True


def compile_kernels() -> None:
    """Compile the tail proof now (or load it from numba's cache): see optim.stability.rigid_kernel."""
    from optim.stability.rigid_kernel import example_loop

    for beta in (0.0, 1e-3):
        _tail_is_clear(example_loop(), beta, 2.0, 3)
