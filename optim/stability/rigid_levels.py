"""Every K > 0 crossover of a rigid loop on its rising range, all levels at once (issue 20).

Notation of optim.stability.fast_rigid.  On [0, θ_r] F̃ = ψ − asin(min(g, 1)) rises, so the K > 0 crossovers
there are its roots at the levels 2πk, k = 0, 1, … (F̃(θ_r) above the last one), one per level, and each lies
in [θ₀, θ_r] (θ₀ the binding crossover of fast_rigid, level 0): for every level F̃(θ₀) = 0 < 2πk < F̃(θ_r).
The roots are independent, so past _VECTOR_MIN levels they are solved together: Newton passes on F̃ over the
array of levels from the chord of F̃ on [θ₀, θ_r] (F̃ is (d + m + ½)θ plus bounded arguments: nearly linear), then
fast_rigid.polish_h's secant step on Im H elementwise.  A level counts as solved when its last Newton step was
below 1e-8 (relative; quadratic convergence leaves the next iterate within rounding of the root) inside (θ₀, θ_r)
with F̃' > 0, AND the polish's secant step lands within 8 ulp (Im H confirms the crossover there); any other level
(typically the first, where the chord start is poorest, and the last, where the zero near −1 bends F̃ just below
θ_r) is solved alone (fast_rigid.bracketed_newton in [θ_{k−1}, θ_r], stopping early where quadratic convergence
shows the root within a quarter ulp and F̃' ≥ slope/2, polished).  The count of roots is the monotonicity argument's, as
before; no root is accepted without its bracket (θ₀, θ_r) and its confirmation.

H is evaluated with CPython's own complex arithmetic written out in real arrays (products and Smith's quotient
term by term; math's sin/cos and numpy's agree bit for bit), so polish_array returns fast_rigid.polish_h's bits at
the same θ; F̃'s atan2/asin/tan in numpy may round a last bit differently from math's and the Newton path differs,
which moves a root by an ulp or two at most (tests/optim/stability/test_rigid_levels.py).

A python loop over levels costs ≈ 6 µs a crossover (the 200-sample-delay loop of issue 20 has 100 of them); the
numpy passes cost ≈ 0.4 µs per operation whatever the length (≈ 250 operations in all), so below _VECTOR_MIN
levels the loop stays (with fast_rigid's evaluators bound to the loop's numbers once: the same operations).
"""

from __future__ import annotations

import math

import numpy as np

from models.discretize import RigidZOH
from optim.stability.fast_rigid import RigidLoop, bracketed_newton, k_equation, rigid_loop

__all__ = ["rigid_crossovers", "k_eq_array", "h_array", "newton_levels", "polish_array"]

_EPS = 2.220446049250313e-16
_HALF_PI = 0.5 * math.pi
_TWO_PI = 2.0 * math.pi


def k_eq_array(L: RigidLoop, beta: float, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """fast_rigid's F̃ − π/2 and its derivative (``_k_eq``; ``_psi`` at β = 0), elementwise: the same formulas, the
    squares shared (the derivative's last bits may differ from the scalar's: it only steers Newton)."""
    half = 0.5 * t
    sh, ch = np.sin(half), np.cos(half)
    st = 2.0 * sh * ch
    sh2, st2 = sh * sh, st * st
    re_p = L.omp - 2.0 * sh2
    den_p = re_p * re_p + st2
    psi = L.slope * t - np.arctan2(re_p, st)
    dphi = L.slope + (L.omp + 2.0 * L.p * sh2) / den_p
    ch2 = 2.0 * ch * ch
    if beta == 0.0:
        for q, omq in L.zeros:
            re_q = ch2 - omq
            psi -= np.arctan2(st, re_q)
            dphi -= (omq + q * ch2) / (re_q * re_q + st2)
        return psi, dphi
    dlr = L.p * st / den_p
    mag = np.sqrt(den_p) / L.lead
    for q, omq in L.zeros:
        re_q = ch2 - omq
        den_q = re_q * re_q + st2
        psi -= np.arctan2(st, re_q)
        dphi -= (omq + q * ch2) / den_q
        dlr += q * st / den_q
        mag /= np.sqrt(den_q)
    g = beta * ch / mag
    cap = g >= 1.0
    if cap.any():
        gc = np.where(cap, 0.0, g)
        dg = gc * (-0.5 * np.tan(half) - dlr)
        return (np.where(cap, psi - _HALF_PI, psi - np.arcsin(gc)),
                np.where(cap, dphi, dphi - dg / np.sqrt((1.0 - gc) * (1.0 + gc))))
    dg = g * (-0.5 * np.tan(half) - dlr)
    return psi - np.arcsin(g), dphi - dg / np.sqrt((1.0 - g) * (1.0 + g))


def _prod(ar, ai, br, bi):
    """CPython's complex product (_Py_c_prod), term by term."""
    return ar * br - ai * bi, ar * bi + ai * br


def _quot(ar, ai, br, bi):
    """CPython's complex quotient (_Py_c_quot, Smith's method with its two branches), term by term."""
    first = np.abs(br) >= np.abs(bi)
    if first.all():                                   # one branch for every element (the usual case): no masks
        r = bi / br
        den = br + bi * r
        return (ar + ai * r) / den, (ai - ar * r) / den
    if not first.any():
        r = br / bi
        den = br * r + bi
        return (ar * r + ai) / den, (ai * r - ar) / den
    r1 = bi / np.where(first, br, 1.0)
    d1 = br + bi * r1
    r2 = br / np.where(first, 1.0, bi)
    d2 = br * r2 + bi
    return (np.where(first, (ar + ai * r1) / d1, (ar * r2 + ai) / d2),
            np.where(first, (ai - ar * r1) / d1, (ai * r2 - ar) / d2))


def h_array(plant: RigidZOH, beta: float, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(Re H, Im H) at each θ: fast_rigid's ``_h`` (H = −1/G_n + β(e^{−jθ} − 1)) elementwise, every complex
    operation of it written out as CPython performs it (a float operand taken as complex with imaginary 0)."""
    sh = np.sin(0.5 * t)
    st = np.sin(t)
    cz = np.cos(t)
    zr = -2.0 * sh * sh                               # z − 1 = (zr, st), without cancellation
    omp, phi12, g0p, g0v, g1p, g1v, _ = plant.coefficients()
    if plant.f == 0.0:
        a, c = plant.f0_numerator()
        nr, ni = a * (cz + 1.0) + c, a * st             # a·(z + 1) + c
    else:
        ir, ii = _quot(1.0, 0.0, cz, st)               # 1/z
        pr, pi_ = g0p + g1p * ir, g1p * ii             # g0p + g1p/z
        vr, vi = g0v + g1v * ir, g1v * ii              # g0v + g1v/z
        nr, ni = _prod(pr, pi_, zr + omp, st)
        nr, ni = nr + phi12 * vr, ni + phi12 * vi
    dt = plant.d * t
    ur, ui = _prod(zr, st, zr + omp, st)               # (z − 1)(z − 1 + 1 − p)
    ur, ui = _prod(ur, ui, np.cos(dt), np.sin(dt))
    ur, ui = _quot(ur, ui, nr, ni)
    if beta == 0.0:   # − 0·(…) changes no bit of a nonzero value
        return -ur, -ui
    return -ur - 2.0 * beta * sh * sh, -ui - beta * st


#: Newton passes over all levels at once; a level not settled by then is solved alone (fast_rigid's scalar path)
_PASSES = 3
#: d ln K / d ln θ above which a β = 0 level's K comes from polish_h's pinned θ and H, not from 2·sin(θ/2)·R(θ)
#: (K ∝ θ² at low θ: 2; it grows without bound towards the zero near −1, where an ulp of θ is many ulps of K)
_STEEP = 6.0
#: fewest levels solved together: below it the python loop is cheaper, hot and above all right after the process
#: slept (a server between requests), where numpy's larger code path pays more cache misses (d = 80, 42 crossovers:
#: 262 µs by the loop against 323 µs; d = 130, 67 crossovers: 385 against 350; 0.5 ms sleep before each call)
_VECTOR_MIN = 48
#: a Newton step below this (relative) leaves the next iterate within rounding of the root (quadratic
#: convergence); the polish's secant step on Im H then confirms it to 8 ulp, else the level is solved alone
_SETTLED = 1e-8


def newton_levels(L: RigidLoop, beta: float, levels: np.ndarray, lo: float, hi: float,
                  x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Newton on F̃ = level for every level at once from the starts ``x``: (iterates, settled) where settled marks
    the levels whose last step was below _SETTLED (relative) with the iterate inside (lo, hi) and F̃' > 0 (F̃ rises
    on [lo, hi] ⊂ [0, θ_r], so a root there is the level's only one)."""
    for _ in range(_PASSES):
        f, df = k_eq_array(L, beta, x)
        if df.min() > 0.0:                                   # the usual case: one reduction, no mask
            rising = True
            step = (f - levels) / df
        else:
            rising = df > 0.0
            step = (f - levels) / np.where(rising, df, np.inf)   # a level where F̃' ≤ 0 stays put, never settled
        x = np.minimum(np.maximum(x - step, lo), hi)   # np.clip's bits, without its wrapper (≈ 1 µs a pass)
        small = np.abs(step) <= _SETTLED * x
        if small.all():
            break
    settled = small & rising & (lo < x) & (x < hi)
    return x, settled


def polish_array(plant: RigidZOH, beta: float, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """fast_rigid.polish_h elementwise: one secant step on Im H from each root, kept where it lowers |Im H|.
    Returns (θ, Re H at θ, confirmed): confirmed where Im H is 0 at t, or the secant step is within 8 ulp of t (t
    was within rounding of H's crossover); elsewhere the caller solves the level alone."""
    n = t.size
    h = 64.0 * _EPS * t
    re, im = h_array(plant, beta, np.concatenate([t, t + h]))
    re0, f0, f1 = re[:n], im[:n], im[n:]
    flat = f1 == f0
    t1 = t - f0 * h / np.where(flat, 1.0, f1 - f0)
    near = np.abs(t1 - t) <= 8.0 * _EPS * t
    confirmed = (f0 == 0.0) | (~flat & near)
    try_ = ~flat & (f0 != 0.0) & (t1 != t) & near & (t1 < math.pi)
    if not try_.any():
        return t, re0, confirmed
    re1, im1 = h_array(plant, beta, np.where(try_, t1, t))
    take = try_ & (np.abs(im1) < np.abs(f0))
    return np.where(take, t1, t), np.where(take, re1, re0), confirmed


def _together(plant: RigidZOH, L: RigidLoop, beta: float, n: int, t0: float, tr: float,
              top: float) -> list[tuple[float, float]]:
    """The roots at the levels 2πk, k = 1…n, by numpy passes over all of them (module docstring)."""
    levels = _TWO_PI * np.arange(1, n + 1)
    # start on the chord of F̃ over [θ₀, θ_r] (F̃ nearly linear: (d + m + ½)θ plus bounded arguments)
    x, settled = newton_levels(L, beta, levels, t0, tr, t0 + (tr - t0) * (levels / top))
    theta, alpha, confirmed = polish_array(plant, beta, x)
    pairs = list(zip(theta.tolist(), alpha.tolist()))
    for i in np.flatnonzero(~(settled & confirmed)).tolist():
        # alone, as _one_by_one solves it: bracketed Newton in [θ_{k−1}, θ_r] (F̃ = 2π(k − 1) < 2πk < F̃(θ_r)),
        # polished; in the lower half (the first levels, where the chord start was poorest: the damping pole bends F̃
        # there) from the passes' last iterate, a few digits from the root (2 evaluations instead of 5); near θ_r
        # (the zero near −1: an ill-conditioned root, its last bits set by the path) from the spacing, as before
        pairs[i] = _level(plant, L, beta, i + 1, [(t0, 0.0), *pairs[:i]], tr,
                          start=float(x[i]) if 2 * i < n else None)
    return pairs


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


def _one_by_one(plant: RigidZOH, L: RigidLoop, beta: float, n: int, t0: float, tr: float) -> list[tuple[float, float]]:
    """The roots at the levels 2πk, k = 1…n, in turn (few levels: numpy's per-call cost exceeds the loop's)."""
    if beta == 0.0 and len(L.zeros) == 1:
        return _undamped_whole(plant, L, n, t0, tr)
    out = [(t0, 0.0)]
    fun, h = _scalar_k_eq(L, beta), _scalar_h(plant)
    for k in range(1, n + 1):
        out.append(_level(plant, L, beta, k, out, tr, fun, h))
    return out[1:]


def rigid_crossovers(plant: RigidZOH, beta: float, first: tuple[float, float], tail,
                     loop: RigidLoop | None = None) -> list[tuple[float, float]] | None:
    """Every K > 0 crossover (θ, α), by frequency, for β below β_max; ``first`` is fast_rigid's (θ, α).

    On [0, θ_r] the crossovers are F̃'s roots at the levels 2πk (k = 0 is ``first``), solved together (module
    docstring); past θ_r, where nothing is monotone, ``tail(θ_r)`` (the scan restricted to [θ_r, π], Nyquist
    included, or the Nyquist point alone where optim.stability.rigid_tail proves the rest clear) lists them.
    None where the fast path has no θ_r (the caller scans everything)."""
    L = loop if loop is not None else rigid_loop(plant)
    if L is None:
        return None
    tr = L.theta_r
    t0, a0 = first
    out = [(t0, a0)]
    if t0 < tr:
        top = (L.half_pis_at_pi - 1) * _HALF_PI if tr == math.pi else k_equation(L, beta, tr)[0]
        n = max(int(top // _TWO_PI), 0)                 # the levels 2πk < top, k ≥ 1, as the scalar loop counts
        while _TWO_PI * (n + 1) < top:
            n += 1
        while n > 0 and not _TWO_PI * n < top:
            n -= 1
        if n >= _VECTOR_MIN:
            out += _together(plant, L, beta, n, t0, tr, top)
        elif n > 0:
            out += _one_by_one(plant, L, beta, n, t0, tr)
    # a tail crossover already listed (within 1e-12): the tail's lie in [θ_r, π] and the roots below θ_r rise
    # with k, so the nearest root is the last one
    seen = [out[-1][0]]
    for t, a in tail(tr):
        if all(abs(t - u) > 1e-12 * t for u in seen):
            out.append((t, a))
            seen.append(t)
    out.sort()
    return [c for c in out if c[1] > 0.0]
