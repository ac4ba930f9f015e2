"""The rigid fast path's levels and its tail proof in pure Python: the twins that optim.stability.rigid_kernel's
compiled loop (with fast_rigid's evaluators, bracketed Newton and polish) and optim.stability.rigid_tail's compiled
proof are held to, bit for bit and verdict for verdict (tests/optim/stability/test_rigid_kernel.py).

This is the exact rung's crossover list as it ran in Python before the kernel (issue 20): fast_rigid's bracketed
Newton on F̃ = 2πk from the spacing of the roots below, polished by one secant step on Im H; at β = 0 with a
whole-sample delay K = 2·sin(θ/2)·R(θ) where K is not steep in θ.  Every operation is fast_rigid's scalar
evaluators' (``_psi``, ``_k_eq``, ``_h``) with the loop's numbers bound once.
"""

from __future__ import annotations

import math

from models.discretize import RigidZOH
from optim.stability.fast_rigid import RigidLoop, _parts
from optim.stability.rigid_tail import _MAX_END_HALVINGS, _MAX_INTERVALS

_EPS = 2.220446049250313e-16
_HALF_PI = 0.5 * math.pi
_TWO_PI = 2.0 * math.pi
#: d ln K / d ln θ above which a β = 0 level's K comes from the polish's H (optim.stability.rigid_kernel._STEEP)
_STEEP = 6.0


# -- fast_rigid's scalar evaluators, bracketed Newton and polish as they ran in Python ---------------------------------

def _psi(L: RigidLoop, t: float) -> tuple[float, float]:
    """(ψ, φ') of ``_parts`` alone, by the same expressions (the K equation at β = 0 needs neither R nor R'/R)."""
    sh, ch = math.sin(0.5 * t), math.cos(0.5 * t)
    st = 2.0 * sh * ch
    re_p = L.omp - 2.0 * sh * sh
    den_p = re_p * re_p + st * st
    phi = L.slope * t - math.atan2(re_p, st)
    dphi = L.slope + (L.omp + 2.0 * L.p * sh * sh) / den_p
    for q, omq in L.zeros:
        re_q = 2.0 * ch * ch - omq
        phi -= math.atan2(st, re_q)
        dphi -= (omq + 2.0 * q * ch * ch) / (re_q * re_q + st * st)
    return phi, dphi


def _k_eq(L: RigidLoop, beta: float, t: float) -> tuple[float, float]:
    """F̃ − π/2 = ψ − asin(min(g, 1)) (0 at the K crossover) and its derivative (non-decreasing on [0, θ_r])."""
    if beta == 0.0:
        return _psi(L, t)
    psi, dphi, r, dlr = _parts(L, t)
    g = beta * math.cos(0.5 * t) / r
    if g >= 1.0:
        return psi - _HALF_PI, dphi
    dg = g * (-0.5 * math.tan(0.5 * t) - dlr)
    return psi - math.asin(g), dphi - dg / math.sqrt((1.0 - g) * (1.0 + g))


#: F̃ − π/2 and its derivative at one θ
k_equation = _k_eq


def bracketed_newton(fun, level: float, lo: float, hi: float, x: float, step_rtol: float = 2.0 * _EPS,
                     bracket_rtol: float = 4.0 * _EPS, quadratic_slope: float = math.inf) -> float:
    """The root of the non-decreasing fun(θ) = level in [lo, hi] (fun(lo) < level ≤ fun(hi); fun returns the value
    and its derivative): Newton steps, kept in the bracket (bisection, geometric while the bracket spans decades),
    to a relative step of ``step_rtol`` or a bracket of ``bracket_rtol`` (by default 2 and 4 ulp).  Shared by the
    rigid fast path and the cable brackets (optim.stability.cable_brackets).

    ``quadratic_slope``: where fun' is at least this, also stop at the Newton iterate once the steps show quadratic
    convergence has put it within a quarter ulp of the root (``newton_done``), one evaluation before the step itself
    falls to an ulp.  Where fun' is smaller the root is ill-conditioned (fun's rounding, ε·|level|, moves it by
    ε·|level|/fun', many ulps), and the ulp rule's path is kept: its last bits are what the caller's polish sees."""
    prev = math.inf
    for _ in range(200):
        if not (lo < x < hi):
            x = math.sqrt(lo * hi) if lo > 0.0 and hi > 8.0 * lo else 0.5 * (lo + hi)
            prev = math.inf
        fx, dfx = fun(x)
        if fx == level:
            return x
        if fx < level:
            lo = x
        else:
            hi = x
        if hi - lo <= bracket_rtol * hi:
            return x
        step = (fx - level) / dfx if dfx > 0.0 else math.inf
        xn = x - step
        if lo <= xn <= hi and (abs(step) <= step_rtol * x or dfx >= quadratic_slope and newton_done(step, prev, xn)):
            return xn   # converged (from one side, hi stays far)
        prev = step
        x = xn
    return x


def newton_done(step: float, prev: float, x: float) -> bool:
    """Whether the Newton iterate x (after ``step``, the one before it ``prev``) is within a quarter ulp of the root:
    the step is below 1e-10 (relative: deep in quadratic convergence) and the error it leaves, |step|·c with the
    observed contraction c = |step|/prev², is ≤ ε/4 relative."""
    a = abs(step)
    return a <= 1e-10 * x and a * a * a <= 0.25 * _EPS * x * prev * prev


def polish(plant: RigidZOH, beta: float, t: float) -> float:
    """One secant step on Im H (the scan's own function) from the root t of F̃: near β_max, K moves by
    ~1e-12 per ulp of θ, and Im H pins θ a few ulp closer than F̃'s sum of arguments does."""
    return polish_h(plant, beta, t)[0]


def polish_h(plant: RigidZOH, beta: float, t: float) -> tuple[float, complex]:
    """``polish`` and H at the θ it returns (its K is Re H: ``re_h`` without evaluating H again)."""
    h = 64.0 * _EPS * t
    v0 = _h(plant, beta, t)
    f0, f1 = v0.imag, _h(plant, beta, t + h).imag
    if f1 == f0 or f0 == 0.0:
        return t, v0
    t1 = t - f0 * h / (f1 - f0)
    if t1 == t:   # the step rounds away: H(t1) would be v0 again
        return t, v0
    if abs(t1 - t) <= 8.0 * _EPS * t and t1 < math.pi:
        v1 = _h(plant, beta, t1)
        if abs(v1.imag) < abs(f0):
            return t1, v1
    return t, v0


def re_h(plant: RigidZOH, beta: float, t: float) -> float:
    """K (dimensionless) of the crossover at θ = t: Re H(θ) by the scan's own formula (RigidZOH.inverse_response).

    Not k(θ) of the docstring (equal at a root), nor 2s(R cos ψ − βs): near β_max K is a small difference
    of O(β) terms, and this form keeps the scan's accuracy there (~4e-14 against the 40-digit reference at
    0.9997·B_max, where the factored form lost ~1.6e-12)."""
    return _h(plant, beta, t).real


def _h(plant: RigidZOH, beta: float, t: float) -> complex:
    """H(θ) = −1/G_n + β(e^{−jθ} − 1), as RigidZOH.inverse_response and the scan compute it."""
    sh = math.sin(0.5 * t)
    st = math.sin(t)
    z = complex(math.cos(t), st)
    zm1 = complex(-2.0 * sh * sh, st)                 # z − 1 without cancellation
    if t == math.pi and plant.inverse_at_nyquist() is not None:
        return complex(-plant.inverse_at_nyquist() - 2.0 * beta * sh * sh, 0.0)
    if plant.f == 0.0:
        omp = plant.coefficients()[0]
        a, c = plant.f0_numerator()
        num = a * (z + 1.0) + c
    else:
        omp, phi12, g0p, g0v, g1p, g1v, _ = plant.coefficients()
        zinv = 1.0 / z
        num = (g0p + g1p * zinv) * (zm1 + omp) + phi12 * (g0v + g1v * zinv)
    dt = plant.d * t
    inv = zm1 * (zm1 + omp) * complex(math.cos(dt), math.sin(dt)) / num
    return complex(-inv.real - 2.0 * beta * sh * sh, -inv.imag - beta * st)


# -- the levels' loop ---------------------------------------------------------------------------------------------

def _scalar_h(plant: RigidZOH):
    """fast_rigid's ``_h`` (H at one θ) with the plant's coefficients bound once: the same operations, so the same
    bits (the per-call unpacking of the coefficients was a sixth of a level's cost)."""
    omp, phi12, g0p, g0v, g1p, g1v, _ = plant.coefficients()
    d, sin, cos = plant.d, math.sin, math.cos
    if plant.f == 0.0:
        a, c = plant.f0_numerator()

        def h(beta: float, t: float) -> complex:
            sh = sin(0.5 * t)
            st = sin(t)
            z = complex(cos(t), st)
            zm1 = complex(-2.0 * sh * sh, st)
            num = a * (z + 1.0) + c
            dt = d * t
            inv = zm1 * (zm1 + omp) * complex(cos(dt), sin(dt)) / num
            return complex(-inv.real - 2.0 * beta * sh * sh, -inv.imag - beta * st)
        return h

    def h_frac(beta: float, t: float) -> complex:
        sh = sin(0.5 * t)
        st = sin(t)
        z = complex(cos(t), st)
        zm1 = complex(-2.0 * sh * sh, st)
        zinv = 1.0 / z
        num = (g0p + g1p * zinv) * (zm1 + omp) + phi12 * (g0v + g1v * zinv)
        dt = d * t
        inv = zm1 * (zm1 + omp) * complex(cos(dt), sin(dt)) / num
        return complex(-inv.real - 2.0 * beta * sh * sh, -inv.imag - beta * st)
    return h_frac


def _scalar_k_eq(L: RigidLoop, beta: float):
    """fast_rigid's F̃ (``k_equation``) at one θ; at β = 0 with one zero (a whole-sample delay) its ``_psi`` with the
    loop's numbers bound once, the same operations (so the same bits)."""
    if beta != 0.0 or len(L.zeros) != 1:
        return lambda t: k_equation(L, beta, t)
    omp, slope, two_p = L.omp, L.slope, 2.0 * L.p
    (q, omq), = L.zeros
    two_q, sin, cos, atan2 = 2.0 * q, math.sin, math.cos, math.atan2

    def psi(t: float) -> tuple[float, float]:
        sh, ch = sin(0.5 * t), cos(0.5 * t)
        st = 2.0 * sh * ch
        re_p = omp - 2.0 * sh * sh
        den_p = re_p * re_p + st * st
        phi = slope * t - atan2(re_p, st)
        dphi = slope + (omp + two_p * sh * sh) / den_p
        re_q = 2.0 * ch * ch - omq
        phi -= atan2(st, re_q)
        dphi -= (omq + two_q * ch * ch) / (re_q * re_q + st * st)
        return phi, dphi
    return psi


def _polish(h, beta: float, t: float) -> tuple[float, float]:
    """fast_rigid.polish_h with the bound H of ``_scalar_h``: (θ, Re H(θ))."""
    dh = 64.0 * _EPS * t
    v0 = h(beta, t)
    f0, f1 = v0.imag, h(beta, t + dh).imag
    if f1 == f0 or f0 == 0.0:
        return t, v0.real
    t1 = t - f0 * dh / (f1 - f0)
    if t1 == t:
        return t, v0.real
    if abs(t1 - t) <= 8.0 * _EPS * t and t1 < math.pi:
        v1 = h(beta, t1)
        if abs(v1.imag) < abs(f0):
            return t1, v1.real
    return t, v0.real


def _next_start(L: RigidLoop, k: int, below, tr: float) -> float:
    """Newton's start for the root at level 2πk from the roots ``below`` it (levels 0…k − 1): the first spacing
    from the slope, then the roots carried on linearly (k = 2) or by their second difference (F̃ nearly linear, its
    slope slowly changing: ~1e-6 from the root at mid levels against ~1e-5 linearly), kept below the middle of
    [θ_{k−1}, θ_r]."""
    lo = below[-1][0]
    if k == 1:
        start = lo + 2.0 * math.pi / (L.slope + 0.5)
    elif k == 2:
        start = lo + (lo - below[-2][0])
    else:
        start = 3.0 * (lo - below[-2][0]) + below[-3][0]
    return min(start, 0.5 * (lo + tr))


def _level(plant: RigidZOH, L: RigidLoop, beta: float, k: int, below: list[tuple[float, float]],
           tr: float, fun=None, h=None, start: float | None = None) -> tuple[float, float]:
    """The root at level 2πk alone, ``below`` the roots at the levels 0…k − 1: fast_rigid's bracketed Newton in
    [θ_{k−1}, θ_r], started from the last spacing of the roots (F̃ is nearly linear there: Newton then starts a few
    digits from the root), then polished.  ``fun``, ``h``: _scalar_k_eq and _scalar_h of this loop, when the caller
    has them; ``start``: a better start than the spacing's (the vectorised passes' last iterate)."""
    lo = below[-1][0]
    if start is None:
        start = _next_start(L, k, below, tr)
    t = bracketed_newton(fun or _scalar_k_eq(L, beta), _TWO_PI * k, lo, tr, start, quadratic_slope=0.5 * L.slope)
    return _polish(h or _scalar_h(plant), beta, t)


def _undamped_whole(plant: RigidZOH, L: RigidLoop, n: int, t0: float, tr: float) -> list[tuple[float, float]]:
    """_one_by_one at β = 0 with one zero (a whole-sample delay), the commonest loop: fast_rigid's bracketed Newton
    and ``_psi`` written out in one loop (the same operations, so the same roots).  At β = 0, H = 2·sin(θ/2)·R·e^{jψ}
    exactly, so at the root K = 2·sin(θ/2)·R(θ), a product of positive terms: taken so where K is not steep in θ
    (_STEEP), else polish_h as before (Im H pins θ where an ulp of θ is many ulps of K).  Against the 30-digit
    reference on 473 crossovers of 40 random devices: the same median (1 ulp) and largest (4.8e-15) error as the
    polished list."""
    h = _scalar_h(plant)
    omp, slope, p, two_p = L.omp, L.slope, L.p, 2.0 * L.p
    (q, omq), = L.zeros
    two_q, sin, cos, atan2, sqrt = 2.0 * q, math.sin, math.cos, math.atan2, math.sqrt
    eps2, eps4, q_eps, lead, inf = 2.0 * _EPS, 4.0 * _EPS, 0.25 * _EPS, L.lead, math.inf
    half_slope, step1, nan = 0.5 * slope, 2.0 * math.pi / (slope + 0.5), math.nan
    out = []
    r1 = r2 = r3 = t0                                     # the last three roots (levels k − 1, k − 2, k − 3)
    for k in range(1, n + 1):
        level, lo, hi = _TWO_PI * k, r1, tr
        # _next_start's start, on the last roots kept in locals
        x = lo + step1 if k == 1 else lo + (lo - r2) if k == 2 else 3.0 * (lo - r2) + r3
        mid = 0.5 * (lo + tr)
        if x > mid:
            x = mid
        t = dphi = nan
        prev = inf
        for _ in range(200):                              # fast_rigid.bracketed_newton, quadratic_slope
            if not (lo < x < hi):
                x = sqrt(lo * hi) if lo > 0.0 and hi > 8.0 * lo else 0.5 * (lo + hi)
                prev = inf
            sh, ch = sin(0.5 * x), cos(0.5 * x)           # fast_rigid._psi
            st = 2.0 * sh * ch
            re_p = omp - 2.0 * sh * sh
            den_p = re_p * re_p + st * st
            fx = slope * x - atan2(re_p, st)
            dphi = slope + (omp + two_p * sh * sh) / den_p
            re_q = 2.0 * ch * ch - omq
            fx -= atan2(st, re_q)
            dphi -= (omq + two_q * ch * ch) / (re_q * re_q + st * st)
            if fx == level:
                t = x
                break
            if fx < level:
                lo = x
            else:
                hi = x
            if hi - lo <= eps4 * hi:
                t = x
                break
            step = (fx - level) / dphi if dphi > 0.0 else inf
            xn = x - step
            a = abs(step)                                 # the ulp rule, or fast_rigid.newton_done's written out
            if lo <= xn <= hi and (a <= eps2 * x or dphi >= half_slope and a <= 1e-10 * xn
                                   and a * a * a <= q_eps * xn * prev * prev):
                t = xn
                break
            prev = step
            x = xn
        else:
            t = x
        # K = H(θ) = 2·sin(θ/2)·R(θ) at a β = 0 crossover (H = 2sR·e^{jψ}, ψ ≡ 0): positive terms, no cancellation,
        # where K is not steep in θ (d ln K/d ln θ = θ·(½cot(θ/2) + R'/R) ≤ _STEEP: an ulp of θ moves K by ≤ 6 ulp);
        # steeper (the last levels, where the zero near −1 lifts R), polish_h's secant on Im H pins θ as before
        sh, ch = sin(0.5 * t), cos(0.5 * t)
        st = 2.0 * sh * ch
        re_p = omp - 2.0 * sh * sh
        re_q = 2.0 * ch * ch - omq
        den_p, den_q = re_p * re_p + st * st, re_q * re_q + st * st
        if t * (0.5 * ch / sh + p * st / den_p + q * st / den_q) <= _STEEP:
            out.append((t, 2.0 * sh * (sqrt(den_p) / lead) / sqrt(den_q)))
        else:
            out.append(_polish(h, 0.0, t))
        r1, r2, r3 = out[-1][0], r1, r2
    return out


def level_roots(plant: RigidZOH, L: RigidLoop, beta: float, n: int, t0: float, tr: float) -> list[tuple[float, float]]:
    """The roots at the levels 2πk, k = 1…n, in turn: (θ, α) pairs."""
    if beta == 0.0 and len(L.zeros) == 1:
        return _undamped_whole(plant, L, n, t0, tr)
    out = [(t0, 0.0)]
    fun, h = _scalar_k_eq(L, beta), _scalar_h(plant)
    for k in range(1, n + 1):
        out.append(_level(plant, L, beta, k, out, tr, fun, h))
    return out[1:]


# -- optim.stability.rigid_tail's proof in Python (its twin, held to the same verdicts) -------------------------------

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
