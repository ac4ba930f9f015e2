"""Exact K_cr(B) and B_max of a damped cable device without a frequency scan (issue 20): certified brackets.

Notation of optim.stability.margins and optim.stability.fast_rigid (dimensionless θ = ωT, α = KT²/m, β = BT/m).
The modal form of the cable plant (models.discretize.StateSpaceZOH.modal_form: an exact integrator and three
modes λ of E₂₂, in w = z − 1) factors the loop as

    G_n(z) = L·Π(z − ζ_i) / ((z − 1)·Π(z − c_k)) · z^{−d−m},   c_k = 1 + λ_k (the rigid pole and the resonance),

ζ_i the roots of the numerator polynomial in w (the anti-resonance pair and the sampling zero(s); m = 1 and
one more zero for a fractional delay).  With Q = z/(z − 1)/G_n = z^s Π(z − c_k)/(L Π(z − ζ_i)), s = d + m + 1:

    H(θ) = −1/G_n + β(e^{−jθ} − 1) = −2j·sin(θ/2)·e^{−jθ/2}·(Q + β),

so (as in fast_rigid, with R = |Q| and φ = arg Q − θ/2 unwrapped, in closed form from the factors) a K > 0
crossover is a root of F(θ) = φ − asin(g) = π/2 (mod 2π), g = β cos(θ/2)/R, where R > β, and there
K = k(θ) = 2s·u/(√(u + β²s²) + βs), s = sin(θ/2), u = R² − β², which rises in R and in θ.  The damper-only
loop −Q is real and positive where F_b = φ + θ/2 = π (mod 2π), with value R (B_max = min R there).

Unlike the rigid loop, R dips at the resonance and peaks at the anti-resonance, and φ falls by ≈ π across the
anti-resonance: nothing is monotone on all of (0, π].  So the axis is split (first at the angles of every pole
and zero) and each piece [a, b] gets closed-form bounds, every one from the factors:

* |z − c| on the arc: its minimum (the arc's nearest point to c) and maximum (the farthest), so
  R_min ≤ R ≤ R_max;
* F' = s − ½ + G·½tan(θ/2) + Σ_k T_{c_k} − Σ_i T_{ζ_i},  T_c = ½ + ((1 − |c|²)/2 + G·|c| sin(θ − arg c))/|z − c|²,
  with G = g/√(1 − g²) ∈ [G_lo, G_hi] from the bounds of R (G = 0 for F_b and for β = 0): each term bounded
  on its own by interval arithmetic (the resonance's two parts, which cancel, are bounded together).

A piece is then (in this order): dropped when R_max ≤ β (no K > 0 crossover: one needs R > β); dropped when
the lower bound k(sin(a/2), R_min) (R_min for F_b) of any K in it is above the best K found; solved when F is
monotone on it (D_lo > 0 or D_hi < 0 with R_min > β): every level π/2 + 2πk between F(a) and F(b) has exactly
one root, found by bracketed Newton (fast_rigid's solver), then refined on Im H itself (the scan's function,
Illinois to 4 ulp, as the scan does) and K = Re H there; dropped when the derivative bounds keep F's whole
range on the piece off every level; otherwise halved.  Pieces are taken by frequency, so the first crossover
found bounds the rest.  The Nyquist point is the scan's (H(π) real: a crossover when positive).

Beside a factor near the unit circle (optim.stability.cable_loop: a resonance within 1e-8, a zero of G within
1e-9) the modal response is known only to e = Σ ferr/|e^{jθ} − c|: there a value F or log R read at a piece's end
within e of a level (or of log β) sends the device to the bounded scan, F's range on a piece is widened by e, and
so is an answer whose crossover has e > cable_loop.MAX_NEAR_ERROR (issue 32: its conditioning, the scan's own
there, no worse than the old 1e-8 gap admitted).  Where the factors are not trusted (the factored Q differs from the modal response by > 1e-9, a factor
within 1e3 of its own error of the unit circle: an undamped cable) or the pieces do not resolve within
a budget, ``None`` is returned and the caller runs the bounded scan (optim.stability.fast_cable), saying so in
the answer's ``path``.  The evaluations (F at one angle, the Newton solve, the polish on Im H, the device's β-free
work kept between calls) are optim.stability.cable_points'.

optim.stability.margins runs the compiled form of this module (optim.stability.cable_kernel, issue 32: the same
operations in the same order, ≈ 10× faster); this Python stays its twin and oracle, held to it bit for bit by
tests/optim/stability/test_cable_kernel.py.
"""

from __future__ import annotations

import math

from optim.stability.cable_loop import MAX_NEAR_ERROR, CableLoop, Factor, cable_loop, expm1j, inverse_response_at
from optim.stability.cable_points import (
    MEMO_MAX,
    Point,
    assemble,
    clear_memo,
    h_at,
    log_r,
    memo_for,
    newton,
    polish,
    r_at,
)
from optim.stability.fast_rigid import bracketed_newton

__all__ = ["CableLoop", "cable_loop", "cable_min_crossing", "clear_memo", "MAX_PIECES"]

_EPS = 2.220446049250313e-16
_TWO_PI = 2.0 * math.pi
#: pieces examined before giving up (the caller then scans).  20,000 (was 400, issue 32): near B_max with a long
#: delay R ≈ β over a wide band, no piece is pruned, and each of F's levels takes pieces of its own (8 of
#: bench_core's 1,000 random cables, 50–200 samples, fell back to the bounded scan at 400; they need up to 19,292;
#: compiled (optim.stability.cable_kernel) a piece costs ≈ 1 µs)
MAX_PIECES = 20_000
#: why the last call returned None (a debug label for bench/bench_cable_fallbacks.py; never in an answer)
last_reason: list[str] = [""]
_PAD = 1e-9          # relative padding of every bound (the factors are known to ~cond·ε ≤ 1e-12)


def _bounds_r(loop: CableLoop, a: float, b: float, pa: Point, pb: Point) -> tuple[float, float, list]:
    """(R_min, R_max, per-factor (d_min, d_max)) on [a, b]: each |e^{jθ} − c| at its ends or its interior extrema."""
    rmin = rmax = 1.0 / loop.lead_abs
    ranges = []
    for f, da, db in zip(loop.factors, pa.dist, pb.dist):
        mn, mx = (da - f.err, db + f.err) if da <= db else (db - f.err, da + f.err)
        if f.t_near is not None and a <= f.t_near <= b:
            mn = f.gap
        if f.t_far is not None and a <= f.t_far <= b:
            mx = 1.0 + f.mag + f.err
        ranges.append((mn, mx))
        if f.sign > 0:
            rmin *= mn
            rmax *= mx
        else:
            rmin /= mx
            rmax /= mn
    return rmin * (1.0 - _PAD), rmax * (1.0 + _PAD), ranges


def _sin_bounds(f: Factor, a: float, b: float, sa: float, sb: float) -> tuple[float, float]:
    mn, mx = (sa, sb) if sa <= sb else (sb, sa)
    if f.t_smax is not None and a <= f.t_smax <= b:
        mx = f.mag
    if f.t_smin is not None and a <= f.t_smin <= b:
        mn = -f.mag
    return mn - f.err, mx + f.err


def _bounds_d(loop: CableLoop, beta: float, a: float, b: float, pa: Point, pb: Point, rmin: float, rmax: float,
              ranges: list, cslope: float) -> tuple[float, float]:
    """Bounds (D_lo, D_hi) of F' on [a, b] (module docstring); R ≥ rmin > β there (or β = 0).

    Two ways, the tighter of each kept: every factor's phase term with its share of G·(log R)' (they cancel
    at the resonance), and the phase terms alone plus G times the bounds of the whole (log R)' (whose sign
    is known where R is monotone)."""
    base = loop.s - 0.5 + cslope
    if beta > 0.0:
        g_lo = beta * math.cos(0.5 * b) / rmax
        g_hi = beta * math.cos(0.5 * a) / rmin
        # 1 − g without cancellation: (R − β + 2β sin²(θ/4))/R (R = β at a split point, θ tiny)
        qa, qb = math.sin(0.25 * a), math.sin(0.25 * b)
        root_hi = math.sqrt(((rmin - beta) + 2.0 * beta * qa * qa) / rmin * (1.0 + g_hi))
        root_lo = math.sqrt(((rmax - beta) + 2.0 * beta * qb * qb) / rmax * (1.0 + g_lo))
        if not root_hi > 0.0:
            return -math.inf, math.inf
        gl, gh = g_lo / root_lo, g_hi / root_hi
        # G·½tan(θ/2) = ½β sin(θ/2)/(R√(1 − g²))
        tan_lo = 0.5 * beta * math.sin(0.5 * a) / rmax
        tan_hi = 0.5 * beta * math.sin(0.5 * b) / (rmin * root_hi)
    else:
        gl = gh = tan_lo = tan_hi = 0.0
    lo = hi = base            # per-factor pairing
    plo = phi_ = base         # phase terms alone
    dl_lo = dl_hi = 0.0       # (log R)'
    for f, (mn, mx), sa, sb in zip(loop.factors, ranges, pa.sin, pb.sin):
        mn2, mx2 = mn * mn, mx * mx
        om_lo, om_hi = f.om_lo, f.om_hi
        p_lo = om_lo / mx2 if om_lo >= 0.0 else om_lo / mn2
        p_hi = om_hi / mn2 if om_hi >= 0.0 else om_hi / mx2
        if gh > 0.0:
            # _sin_bounds, inline (the hot loop)
            smn, smx = (sa, sb) if sa <= sb else (sb, sa)
            ts = f.t_smax
            if ts is not None and a <= ts <= b:
                smx = f.mag
            ts = f.t_smin
            if ts is not None and a <= ts <= b:
                smn = -f.mag
            smn -= f.err
            smx += f.err
            n_lo = om_lo + (gl * smn if smn >= 0.0 else gh * smn)
            n_hi = om_hi + (gh * smx if smx >= 0.0 else gl * smx)
            t_lo = n_lo / mx2 if n_lo >= 0.0 else n_lo / mn2
            t_hi = n_hi / mn2 if n_hi >= 0.0 else n_hi / mx2
            s_lo = smn / mx2 if smn >= 0.0 else smn / mn2
            s_hi = smx / mn2 if smx >= 0.0 else smx / mx2
        else:
            t_lo, t_hi, s_lo, s_hi = p_lo, p_hi, 0.0, 0.0
        if f.sign > 0:
            lo += 0.5 + t_lo
            hi += 0.5 + t_hi
            plo += 0.5 + p_lo
            phi_ += 0.5 + p_hi
            dl_lo += s_lo
            dl_hi += s_hi
        else:
            lo -= 0.5 + t_hi
            hi -= 0.5 + t_lo
            plo -= 0.5 + p_hi
            phi_ -= 0.5 + p_lo
            dl_lo -= s_hi
            dl_hi -= s_lo
    lo += tan_lo
    hi += tan_hi
    if gh > 0.0:
        lo = max(lo, plo + tan_lo + (gl * dl_lo if dl_lo >= 0.0 else gh * dl_lo))
        hi = min(hi, phi_ + tan_hi + (gh * dl_hi if dl_hi >= 0.0 else gl * dl_hi))
    pad = _PAD * (abs(lo) + abs(hi) + loop.s)
    return lo - pad, hi + pad


def _dlogr_bounds(loop: CableLoop, a: float, b: float, pa: Point, pb: Point, ranges: list) -> tuple[float, float]:
    """Bounds of (log R)' = Σ ±|c| sin(θ − arg c)/|e^{jθ} − c|² on [a, b]."""
    lo = hi = 0.0
    for f, (mn, mx), sa, sb in zip(loop.factors, ranges, pa.sin, pb.sin):
        smn, smx = _sin_bounds(f, a, b, sa, sb)
        t_lo = smn / (mx * mx) if smn >= 0.0 else smn / (mn * mn)
        t_hi = smx / (mn * mn) if smx >= 0.0 else smx / (mx * mx)
        if f.sign > 0:
            lo += t_lo
            hi += t_hi
        else:
            lo -= t_hi
            hi -= t_lo
    pad = _PAD * (abs(lo) + abs(hi))
    return lo - pad, hi + pad


def _ferr(loop: CableLoop, dist: list) -> float:
    """The modal response's relative error bound at a point whose distances to the factors are ``dist``: Σ ferr/dist
    over the near factors (optim.stability.cable_loop's docstring)."""
    e = 0.0
    for f, d in zip(loop.factors, dist):
        if f.ferr > 0.0:
            e += f.ferr / d
    return e


def _solve(fun, level: float, lo: float, hi: float, x: float) -> float:
    """fast_rigid's bracketed Newton (fun non-decreasing, fun(lo) < level ≤ fun(hi)), stopped at a relative step
    of 1e-12: _polish then pins the root on Im H itself, to 4 ulp."""
    return bracketed_newton(fun, level, lo, hi, x, step_rtol=1e-12, bracket_rtol=1e-12)


def _k_of(beta: float, t: float, r: float) -> float:
    """k(θ) of the module docstring: K at a crossover with |Q| = r (a lower bound when r, θ are)."""
    if beta == 0.0:
        return 2.0 * math.sin(0.5 * t) * r
    s = math.sin(0.5 * t)
    u = (r - beta) * (r + beta)
    if u <= 0.0:
        return 0.0
    return 2.0 * s * u / (math.sqrt(u + beta * beta * s * s) + beta * s)


def cable_min_crossing(loop: CableLoop, beta: float, theta_lo: float, damper: bool = False
                       ) -> tuple[tuple[float, float] | None, int] | None:
    """((θ, α) of the K > 0 crossover of least α on [θ_lo, π], or None when there is none; pieces examined).

    ``damper``: the damper-only loop −Q (β = 0), whose least crossover value is β_max.  Returns None (not a
    guess) where the pieces do not resolve within MAX_PIECES or a root cannot be refined on Im H."""
    if damper:
        beta = 0.0
    cslope = 0.5 if damper else 0.0
    level0 = math.pi if damper else 0.5 * math.pi
    memo = memo_for(loop)
    inv_pi = memo.get("inv_pi")
    if inv_pi is None:
        inv_pi = memo["inv_pi"] = inverse_response_at(loop.modal, loop.d, math.pi)
    nyq = h_at(loop, beta, damper, math.pi, inv_pi).real
    best = nyq if nyq > 0.0 else math.inf
    # F's roots (θ, K by the factored form); refined on Im H at the end, only those that may be the least
    found: list[tuple[float, float, tuple[float, float, float, bool]]] = []
    cuts = [theta_lo] + [x for x in loop.splits if theta_lo < x < math.pi] + [math.pi]
    fvals: dict[float, tuple[float, float, float]] = {}

    def pt(x: float) -> Point:
        got = memo.get(x)
        if got is None:
            got = Point(loop, x)
            if len(memo) < MEMO_MAX:
                memo[x] = got
        return got

    def f_at(x: float) -> tuple[float, float, float]:
        v = fvals.get(x)
        if v is None:
            v = fvals[x] = assemble(beta, cslope, x, *pts[x].base(loop))
        return v

    def bounds_r(a: float, b: float) -> tuple[float, float, list]:
        key = ("r", a, b)
        got = memo.get(key)
        if got is None:
            got = _bounds_r(loop, a, b, pts[a], pts[b])
            if len(memo) < MEMO_MAX:
                memo[key] = got
        return got

    def dlogr_bounds(a: float, b: float, ranges: list) -> tuple[float, float]:
        key = ("dl", a, b)
        got = memo.get(key)
        if got is None:
            got = _dlogr_bounds(loop, a, b, pts[a], pts[b], ranges)
            if len(memo) < MEMO_MAX:
                memo[key] = got
        return got

    pts = {x: pt(x) for x in cuts}
    near = any(f.ferr > 0.0 for f in loop.factors)
    # pieces by frequency; the flag: R ≥ β proved on the piece (R = β at its end, R monotone)
    stack = [(cuts[i], cuts[i + 1], False, None) for i in range(len(cuts) - 2, -1, -1)]
    pieces = 0
    log_beta = math.log(beta) if beta > 0.0 else -math.inf
    while stack:
        a, b, above, skip = stack.pop()
        pieces += 1
        if pieces > MAX_PIECES or not (b - a > 4.0 * _EPS * b):
            last_reason[0] = "budget" if pieces > MAX_PIECES else f"piece too narrow at {a:.6g}"
            return None
        pa, pb = pts[a], pts[b]
        rmin, rmax, ranges = bounds_r(a, b)
        if above:
            rmin = max(rmin, beta)
        if rmax <= beta:
            continue                              # no K > 0 crossover where R ≤ β
        lower = rmin if damper else _k_of(beta, a, rmin)
        if lower * (1.0 - 1e-9) > best:
            continue
        if beta > 0.0 and not (rmin > beta or above):
            # R crosses β on [a, b]: where R is monotone the crossing is one root, split there
            dl_lo, dl_hi = dlogr_bounds(a, b, ranges)
            if dl_lo > 0.0 or dl_hi < 0.0:
                up = dl_lo > 0.0
                ra, rb = math.log(pa.base(loop)[3]), math.log(pb.base(loop)[3])
                if near:
                    if abs(ra - log_beta) <= _ferr(loop, pa.dist) or abs(rb - log_beta) <= _ferr(loop, pb.dist):
                        last_reason[0] = "near factor: R within its error of beta"
                        return None
                low_end, high_end = (ra, rb) if up else (rb, ra)
                if high_end <= log_beta:
                    continue
                if low_end >= log_beta:
                    stack.append((a, b, True, skip))
                    pieces -= 1
                    continue
                # start where log R, interpolated in log θ (R ∝ θ^p at low θ) or in θ, meets log β
                frac = (log_beta - ra) / (rb - ra)
                x0 = a * (b / a) ** frac if b > 2.0 * a else a + frac * (b - a)
                if up:
                    ts = _solve(lambda x: log_r(loop, x), log_beta, a, b, x0)
                else:
                    ts = _solve(lambda x: tuple(-v for v in log_r(loop, x)), -log_beta, a, b, x0)
                if not a < ts < b:
                    last_reason[0] = "R = beta split outside"
                    return None
                pts[ts] = pt(ts)
                stack.append((ts, b, True, skip) if up else (a, ts, True, skip))
                pieces -= 1
                continue
        elif beta == 0.0 or rmin > beta or above:
            dlo, dhi = _bounds_d(loop, beta, a, b, pa, pb, rmin,
                                 rmax, ranges, cslope)
            (fa, dfa, _), (fb, dfb, _) = f_at(a), f_at(b)
            e = 0.0
            if near:
                # F read within its error of a level at an end: which side of it is not known (at π, H is real and
                # F a multiple of π: the Nyquist point, the scan's own; after a root, its level is not this piece's)
                e_a, e_b = _ferr(loop, pa.dist), _ferr(loop, pb.dist)
                e = max(e_a, e_b)
                n_a = math.floor((fa - level0) / _TWO_PI + 0.5)
                n_b = math.floor((fb - level0) / _TWO_PI + 0.5)
                if (abs(fa - (level0 + _TWO_PI * n_a)) <= e_a and n_a != skip) or \
                        (abs(fb - (level0 + _TWO_PI * n_b)) <= e_b and b != math.pi):
                    last_reason[0] = "near factor: a level within F's error"
                    return None
            if dlo > 0.0 or dhi < 0.0:
                got = _first_root(loop, beta, damper, cslope, level0, a, b, fa, fb, dlo > 0.0, nyq, skip, dfa, dfb)
                if got is False:
                    continue                      # no level on this piece
                if got is None:
                    pass                          # many levels on it: halve it first (pruning acts on halves)
                else:
                    t, v, k = got
                    if v > 0.0:
                        found.append((t, v, (a, b, level0 + _TWO_PI * k, dlo > 0.0)))
                        best = min(best, v)
                    if t >= b:
                        continue
                    # the rest of the piece, past this root, is a piece of its own (bounded, pruned, solved)
                    if t not in pts:
                        pts[t] = pt(t)
                    stack.append((t, b, above, k))
                    continue
            f_min, f_max = _range(fa, fb, dlo, dhi, b - a)
            f_min, f_max = f_min - e, f_max + e
            if level0 + _TWO_PI * math.ceil((f_min - level0) / _TWO_PI) > f_max:
                continue                          # F's range on [a, b] holds no level
        mid = math.sqrt(a * b) if b > 1000.0 * a else 0.5 * (a + b)   # geometric across decades (low θ)
        pts[mid] = pt(mid)
        stack.append((mid, b, above, skip))
        stack.append((a, mid, above, skip))
    out = [(math.pi, nyq)] if nyq > 0.0 else []
    for t, v, piece in found:
        if v <= best * (1.0 + 1e-6):
            got = polish(loop, beta, damper, t, piece)
            if got is None:
                last_reason[0] = "polish failed"
                return None
            if got[1] > 0.0 and not (nyq > 0.0 and math.pi - got[0] <= 1e-9):
                out.append(got)
        elif near:
            # a root left unpolished as above the least: unless beside a near factor its value may be that much low
            zm1 = expm1j(t)
            e = _ferr(loop, [abs(zm1 - f.w) for f in loop.factors])
            if e > MAX_NEAR_ERROR and v * (1.0 - e) <= best * (1.0 + 1e-6):
                last_reason[0] = "near factor: a root above the least too ill-conditioned"
                return None
    if near:
        for t, _ in out:
            zm1 = expm1j(t)
            if _ferr(loop, [abs(zm1 - f.w) for f in loop.factors]) > MAX_NEAR_ERROR:
                last_reason[0] = "near factor: crossover too ill-conditioned"
                return None
    if not out:
        return None, pieces
    return min(out, key=lambda c: (c[1], c[0])), pieces


def _first_root(loop: CableLoop, beta: float, damper: bool, cslope: float, level0: float, a: float, b: float,
                fa: float, fb: float, up: bool, nyq: float, skip: int | None, dfa: float, dfb: float):
    """The lowest-frequency root of F on a piece where F is monotone, with its K by the factored form:
    (θ, K, level index); False when no level lies between F(a) and F(b) (``skip``: a level already solved at
    a); None when more than two do (the caller halves the piece: the halves may be pruned by their bounds)."""
    lo_v, hi_v = (fa, fb) if up else (fb, fa)
    k_lo = math.ceil((lo_v - level0) / _TWO_PI)
    k_hi = math.floor((hi_v - level0) / _TWO_PI)
    last_nyq = b == math.pi and nyq > 0.0
    ks = [k for k in (range(k_lo, k_hi + 1) if up else range(k_hi, k_lo - 1, -1))   # by frequency
          if k != skip and not (last_nyq and abs(level0 + _TWO_PI * k - fb) < 1e-6)]   # (π: the Nyquist point)
    if not ks:
        return False
    if len(ks) > 2 and b - a > 1e-6 * b:
        return None
    level = level0 + _TWO_PI * ks[0]
    # start where the chord through (a, F(a)), (b, F(b)) meets the level (F is monotone on the piece)
    # start at the median of the chord's and the two end tangents' meetings with the level: for F concave (or
    # convex) on the piece it is the tangent estimate nearest the root, from the side Newton converges from
    x0 = a + (level - fa) / (fb - fa) * (b - a) if fb != fa else 0.5 * (a + b)
    if dfa * dfb > 0.0 and (dfa > 0.0) == up:
        x0 = sorted((x0, a + (level - fa) / dfa, b - (fb - level) / dfb))[1]
    x0 = min(max(x0, a + 1e-3 * (b - a)), b - 1e-3 * (b - a))
    root = newton(loop, beta, cslope, level, a, b, fa, fb, x0, up)
    r = r_at(loop, root)
    return root, (r if damper else _k_of(beta, root, r)), ks[0]


def _range(fa: float, fb: float, dlo: float, dhi: float, length: float) -> tuple[float, float]:
    """Bounds of F on [a, b] from F(a), F(b) and dlo ≤ F' ≤ dhi (padded)."""
    if dlo >= 0.0:
        f_min = fa
    elif dhi <= 0.0:
        f_min = fb
    else:
        t = min(max((fb - fa - dhi * length) / (dlo - dhi), 0.0), length)
        f_min = max(fa + dlo * t, fb - dhi * (length - t))
    if dhi <= 0.0:
        f_max = fa
    elif dlo >= 0.0:
        f_max = fb
    else:
        t = min(max((fb - fa - dlo * length) / (dhi - dlo), 0.0), length)
        f_max = min(fa + dhi * t, fb - dlo * (length - t))
    pad = 1e-9 * (abs(fa) + abs(fb) + 1.0)
    return min(f_min, fa, fb) - pad, max(f_max, fa, fb) + pad
