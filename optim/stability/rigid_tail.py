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

The exact rung runs the compiled twin of this proof, optim.stability.rigid_kernel.tail_is_clear (step for step:
test_rigid_kernel.py holds their verdicts equal on random devices); this module is the readable reference.
"""

from __future__ import annotations

import math

from optim.stability.fast_rigid import RigidLoop

__all__ = ["tail_is_clear"]

_TWO_PI = 2.0 * math.pi
#: interval evaluations before giving up (the scan decides then)
_MAX_INTERVALS = 64
#: halvings of π − θ_r searched for the end interval [c, π] on which F̃ is monotone
_MAX_END_HALVINGS = 60


def _point(L: RigidLoop, beta: float, t: float) -> tuple[float, tuple[float, ...], float]:
    """(I(θ), (arg(z + q_i)…), g(θ)) at θ = t < π, with the formulas of fast_rigid._parts."""
    sh, ch = math.sin(0.5 * t), math.cos(0.5 * t)
    st = 2.0 * sh * ch
    re_p = L.omp - 2.0 * sh * sh
    den_p = re_p * re_p + st * st
    mag = math.sqrt(den_p) / L.lead
    args = []
    for q, omq in L.zeros:
        re_q = 2.0 * ch * ch - omq
        args.append(math.atan2(st, re_q))
        mag /= math.sqrt(re_q * re_q + st * st)
    g = beta * ch / mag if beta > 0.0 else 0.0
    inc = L.slope * t - math.atan2(re_p, st) - (math.asin(g) if g < 1.0 else 0.5 * math.pi)
    return inc, tuple(args), g


def _at_pi(L: RigidLoop) -> tuple[float, tuple[float, ...], float]:
    """The same at θ = π, exactly: arg(z + q) = π inside the unit circle, 0 outside; g(π) = 0."""
    args = tuple(math.pi if q < 1.0 else 0.0 for q, _ in L.zeros)
    return (L.half_pis_at_pi - 1) * 0.5 * math.pi + sum(args), args, 0.0


def _clear(lo: float, hi: float) -> bool:
    """No multiple of 2π in [lo, hi], with a rounding margin."""
    pad = 1e-11 * (1.0 + abs(lo) + abs(hi))
    lo, hi = lo - pad, hi + pad
    return math.floor(hi / _TWO_PI) * _TWO_PI < lo


def _interval_clear(L: RigidLoop, a: float, b: float, pa, pb) -> bool:
    inc_a, args_a, _ = pa
    inc_b, args_b, _ = pb
    lo, hi = inc_a, inc_b
    for (q, _), xa, xb in zip(L.zeros, args_a, args_b):
        if q < 1.0:
            lo -= xb
            hi -= xa
        else:   # arg(z + q) peaks at acos(−1/q) at asin(1/q)
            tm = math.acos(-1.0 / q)
            top = math.asin(1.0 / q) if a <= tm <= b else max(xa, xb)
            lo -= top
            hi -= min(xa, xb)
    return _clear(lo, hi)


def _slope_sign_on_end(L: RigidLoop, beta: float, c: float) -> int:
    """+1 / −1 when F̃' > 0 / < 0 on all of [c, π] (c ≥ π/2) by the bounds of the module docstring, else 0."""
    sh, ch = math.sin(0.5 * c), math.cos(0.5 * c)
    st = 2.0 * sh * ch
    re_p = L.omp - 2.0 * sh * sh
    den_p = re_p * re_p + st * st
    p = L.p
    up = L.slope + (L.omp + 2.0 * p * sh * sh) / den_p     # Re z/(z − p) at c (falls on [c, π])
    low = L.slope + 1.0 / (1.0 + p)
    mag = math.sqrt(den_p) / L.lead
    dlr = p
    for q, omq in L.zeros:
        re_q = 2.0 * ch * ch - omq
        den_q = re_q * re_q + st * st
        rq = (omq + 2.0 * q * ch * ch) / den_q                # Re z/(z + q) at c
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


def tail_is_clear(L: RigidLoop, beta: float) -> bool:
    """True when provably no K > 0 crossover lies in [θ_r, π) (the Nyquist point itself is the caller's)."""
    a = L.theta_r
    if not (math.pi / 2 <= a < math.pi) or any(omq == 0.0 for _, omq in L.zeros):
        return a >= math.pi
    end = _at_pi(L)
    b = math.pi
    if ((L.half_pis_at_pi - 1) // 2) % 2 == 0:
        # F̃(π) = (half_pis_at_pi − 1)·π/2 sits on a level: find c with F̃ monotone on [c, π], then F̃(c) must lie
        # within 2π of the level on its side (F̃ runs from F̃(c) to the level without meeting another)
        level = end[0] - sum(end[1])
        eps = math.pi - a
        for _ in range(_MAX_END_HALVINGS):
            c = math.pi - eps
            sign = _slope_sign_on_end(L, beta, c)
            if sign:
                break
            eps *= 0.5
        else:
            return False
        pc = _point(L, beta, c)
        fc = pc[0] - sum(pc[1])
        if not (level < fc < level + _TWO_PI if sign < 0 else level - _TWO_PI < fc < level):
            return False
        if abs(fc - level) <= 1e-11 * (1.0 + abs(level)):
            return False
        if c <= a:
            return True
        b, end = c, pc
    stack = [(a, b, _point(L, beta, a), end)]
    budget = _MAX_INTERVALS
    while stack:
        lo, hi, plo, phi = stack.pop()
        if _interval_clear(L, lo, hi, plo, phi):
            continue
        budget -= 1
        if budget <= 0 or hi - lo <= 1e-12 * hi:
            return False
        mid = 0.5 * (lo + hi)
        pm = _point(L, beta, mid)
        stack.append((mid, hi, pm, phi))
        stack.append((lo, mid, plo, pm))
    return True
