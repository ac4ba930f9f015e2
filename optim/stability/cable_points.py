"""The cable brackets' evaluations (optim.stability.cable_brackets, issue 20): F, F' and R at one angle, the Newton
solve on a piece where F is monotone, the polish of its root on Im H, and the device's β-free work kept between
calls.  Notation of optim.stability.cable_brackets (its module docstring)."""

from __future__ import annotations

import cmath
import math

from optim.stability.cable_loop import CableLoop, expm1j, inverse_response_at

__all__ = ["parts", "branch", "assemble", "point", "r_at", "newton", "Point", "MEMO_MAX", "clear_memo", "memo_for",
           "log_r", "h_at", "polish"]

_EPS = 2.220446049250313e-16
_TWO_PI = 2.0 * math.pi


def parts(loop: CableLoop, t: float) -> tuple[float, float, float, float, complex, complex]:
    """What F needs at θ = t that does not depend on β: (arg Q − θ/2 by the modal response, principal value;
    (arg Q)' − ½ from the factors; (log R)'; R; e^{jθ} − 1; e^{−jθ})."""
    sh = math.sin(0.5 * t)
    st = math.sin(t)
    ct = math.cos(t)
    zm1 = complex(-2.0 * sh * sh, st)
    zc = complex(ct, -st)
    # (log Q)' = j·z·Σ ±1/(z − c): (arg Q)' = Re, (log R)' = −Im of z·Σ (Newton's slope, F')
    acc = 0j
    for w in loop.num_w:
        acc += 1.0 / (zm1 - w)
    for w in loop.den_w:
        acc -= 1.0 / (zm1 - w)
    zs = complex(ct, st) * acc
    q = inverse_response_at(loop.modal, loop.d, t) / (1.0 - zc)
    return cmath.phase(q) - 0.5 * t, loop.s - 0.5 + zs.real, -zs.imag, abs(q), zm1, zc


def branch(loop: CableLoop, t: float, zm1: complex, zc: complex, exact: float) -> int:
    """k with exact + 2πk the continuous φ: the factors' arguments summed (module docstring of _point)."""
    phi = (loop.s - 0.5) * t - loop.lead_arg
    phase = cmath.phase
    for w, inside, base, rot, _, _, _ in loop.num:
        phi += t + phase((zm1 - w) * zc) if inside else base + phase((zm1 - w) * rot)
    for w, inside, base, rot, _, _, _ in loop.den:
        phi -= t + phase((zm1 - w) * zc) if inside else base + phase((zm1 - w) * rot)
    return round((phi - exact) / _TWO_PI)


def assemble(beta: float, cslope: float, t: float, phi_u: float, dphi0: float, dlr: float, r: float
              ) -> tuple[float, float, float]:
    """(F, F', R) from the β-free parts (phi_u: φ unwrapped)."""
    phi = phi_u + cslope * t
    dphi = dphi0 + cslope
    if beta == 0.0:
        return phi, dphi, r
    g = beta * math.cos(0.5 * t) / r
    if g >= 1.0:
        return phi - 0.5 * math.pi, dphi, r
    root = math.sqrt((1.0 - g) * (1.0 + g))
    return phi - math.asin(g), dphi + g / root * (0.5 * math.tan(0.5 * t) + dlr), r


def point(loop: CableLoop, beta: float, cslope: float, t: float,
           window: tuple[float, float] | None = None) -> tuple[float, float, float]:
    """(F, F', R) at θ = t (F = φ + cslope·θ − asin g; g = 0 when β = 0).

    φ and R are the modal response's (the scan's function: Q = (1/G_n)/(1 − e^{−jθ})); the factors only
    unwrap φ (their phase is off by ≲ err/gap ≤ 1e-3 rad near a zero, far below the π that would matter), and
    give F'.  arg(e^{jθ} − c) on [0, π], continuously: θ + Arg(1 − c e^{−jθ}) for c inside the unit circle,
    arg(−c) + Arg(1 − z/c) outside (both Args within ±π/2).  ``window``: F is known to lie in it (t inside a
    bracket of a piece where F is monotone, F at the bracket's ends): when it holds one branch only, that one
    is F's (the one the factors pick), found without the factors' arguments (the Newton steps' hot path)."""
    exact, dphi0, dlr, r, zm1, zc = parts(loop, t)
    k = None
    if window is not None:
        lo, hi = window
        pad = 1e-6 * (1.0 + abs(lo) + abs(hi))
        g = beta * math.cos(0.5 * t) / r
        sub = 0.0 if beta == 0.0 else 0.5 * math.pi if g >= 1.0 else math.asin(g)
        base = exact + cslope * t - sub
        k = math.ceil((lo - pad - base) / _TWO_PI)
        if k != math.floor((hi + pad - base) / _TWO_PI):
            k = None                              # two branches in the window (or none: rounding): the factors decide
    if k is None:
        k = branch(loop, t, zm1, zc, exact)
    return assemble(beta, cslope, t, exact + _TWO_PI * k, dphi0, dlr, r)


def r_at(loop: CableLoop, t: float) -> float:
    """R = |Q| at θ = t, as _point computes it."""
    return abs(inverse_response_at(loop.modal, loop.d, t) / (1.0 - complex(math.cos(t), -math.sin(t))))


def newton(loop: CableLoop, beta: float, cslope: float, level: float, a: float, b: float, fa: float, fb: float,
            x: float, up: bool) -> float:
    """The root of F = level on [a, b], F monotone there (rising when ``up``; F(a), F(b) given): fast_rigid's
    bracketed_newton (on −F when falling; its steps in log θ while the bracket spans a ratio > 4) to a relative
    step or bracket of 1e-12 (_polish then pins the root on Im H itself, to 4 ulp), F unwrapped against its
    values at the current bracket's ends."""
    lev = level if up else -level
    lo, hi = a, b
    f_lo, f_hi = fa, fb
    for _ in range(200):
        if not (lo < x < hi):
            x = math.sqrt(lo * hi) if lo > 0.0 and hi > 8.0 * lo else 0.5 * (lo + hi)
        f, df, _ = point(loop, beta, cslope, x, (f_lo, f_hi) if up else (f_hi, f_lo))
        fx, dfx = (f, df) if up else (-f, -df)
        if fx == lev:
            return x
        if fx < lev:
            lo, f_lo = x, f
        else:
            hi, f_hi = x, f
        if hi - lo <= 1e-12 * hi:
            return x
        if dfx > 0.0:
            step = (fx - lev) / dfx
            u = -step / x
            # a bracket spanning a ratio > 4 (low θ, where F ≈ A + B·log θ): the Newton step in log θ
            xn = x * math.exp(u) if hi > 4.0 * lo and -50.0 < u < 50.0 else x - step
        else:
            xn = -math.inf                    # bisect
        if abs(xn - x) <= 1e-12 * x and lo <= xn <= hi:   # converged (from one side, hi stays far)
            return xn
        x = xn
    return x


class Point:
    """Per factor, |e^{jθ} − c| and |c| sin(θ − arg c) at one angle; the β-free parts of F there on first use (a
    pruned piece never needs them).  Independent of β: kept for the device (_memo)."""

    __slots__ = ("t", "dist", "sin", "_base")

    def __init__(self, loop: CableLoop, t: float):
        zm1 = expm1j(t)
        z = zm1 + 1.0
        self.t = t
        self._base: tuple[float, float, float, float] | None = None
        self.dist = [abs(zm1 - f.w) for f in loop.factors]
        self.sin = [(z * f.c.conjugate()).imag for f in loop.factors]

    def base(self, loop: CableLoop) -> tuple[float, float, float, float]:
        """(φ unwrapped, (arg Q)' − ½, (log R)', R) at t."""
        if self._base is None:
            exact, dphi0, dlr, r, zm1, zc = parts(loop, self.t)
            self._base = (exact + _TWO_PI * branch(loop, self.t, zm1, zc, exact), dphi0, dlr, r)
        return self._base


#: the β-free work of the last device's calls (points, and pieces' bounds of R): a design, a boundary or a study
#: asks K_cr(B) of one device at many B.  One device only (bounded memory); values that depend on the device
#: alone, so an answer is the same, to the bit, whether they were found now or before.
MEMO_MAX = 4096
_last_memo: tuple = (None, {})


def clear_memo() -> None:
    """Forget the kept work (tests: an answer must not depend on it)."""
    global _last_memo
    _last_memo = (None, {})


def memo_for(loop: CableLoop) -> dict:
    global _last_memo
    held, memo = _last_memo
    if held is not loop:
        memo = {}
        _last_memo = (loop, memo)
    return memo


def log_r(loop: CableLoop, t: float) -> tuple[float, float]:
    """(log R, (log R)') at θ = t: R = |Q| by the modal response (as _point), the slope from the factors."""
    sh = math.sin(0.5 * t)
    st = math.sin(t)
    ct = math.cos(t)
    zm1 = complex(-2.0 * sh * sh, st)
    acc = 0j
    for w in loop.num_w:
        acc += 1.0 / (zm1 - w)
    for w in loop.den_w:
        acc -= 1.0 / (zm1 - w)
    q = inverse_response_at(loop.modal, loop.d, t) / (1.0 - complex(ct, -st))
    return math.log(abs(q)), -(complex(ct, st) * acc).imag


def h_at(loop: CableLoop, beta: float, damper: bool, t: float, inv: complex | None = None) -> complex:
    """H(θ) (the K loop at β, or the damper-only loop); ``inv``: 1/G_n(e^{jθ}) when known."""
    if inv is None:
        inv = inverse_response_at(loop.modal, loop.d, t)
    if damper:
        return -inv / (-expm1j(-t))
    return -inv + beta * expm1j(-t)


def polish(loop: CableLoop, beta: float, damper: bool, t0: float, piece: tuple[float, float, float, bool]
            ) -> tuple[float, float] | None:
    """The root of Im H next to t0 (F's root on ``piece`` = (a, b, level, F rising), F monotone there), bracketed and
    solved to 4 ulp as the scan solves it; (θ, Re H).  F's sum of arguments pins θ to ~ε/θ·Σ|terms|, Im H
    to ~ε: the bracket widens from 1e-12θ while F stays within 1 rad of the level at its ends (no other
    zero of Im H, the K < 0 ones included, can lie between)."""
    a, b, level, up = piece
    cslope = 0.5 if damper else 0.0

    seen: dict[float, complex] = {}

    def f(x: float) -> float:
        v = seen[x] = h_at(loop, beta, damper, x)
        return v.imag

    f0 = f(t0)
    if f0 == 0.0:
        return t0, seen[t0].real
    bracket = None
    for w in (1e-12, 1e-10, 1e-8, 1e-6, 1e-4):
        lo, hi = max(t0 * (1.0 - w), a), min(t0 * (1.0 + w), b, math.pi)
        if w > 1e-9 and not (abs(point(loop, beta, cslope, lo)[0] - level) < 1.0
                             and abs(point(loop, beta, cslope, hi)[0] - level) < 1.0):
            return None
        # the side Im H points to first (it rises with F where β = 0, where arg H = F − level): one probe
        # fewer when it does, the same bracket either way
        for side_hi in ((True, False) if (f0 < 0.0) == up else (False, True)):
            x = hi if side_hi else lo
            fx = f(x)
            if (x > t0 if side_hi else x < t0) and (fx > 0) != (f0 > 0):
                bracket = (t0, x, f0, fx) if side_hi else (x, t0, fx, f0)
                break
        if bracket is not None:
            break
    if bracket is None:
        return None
    a, b, fa, fb = bracket
    side = 0
    tol = 4 * _EPS
    for it in range(200):
        if abs(b - a) <= tol * max(abs(a), abs(b)):
            break
        mid = 0.5 * (a + b)
        x = b - fb * (b - a) / (fb - fa) if fb != fa else mid
        lo, hi = (a, b) if a < b else (b, a)
        m = 2.0 * _EPS * hi
        if not (lo <= x <= hi) or it % 8 == 7:     # Illinois; a bisection now and then
            x = mid
        # a step onto or within 2 ulp of an end goes 2 ulp inside (the root sits by that end: one more step
        # closes the bracket to 4 ulp, where Illinois alone would creep up on it by halvings)
        elif x - lo < m:
            x = min(lo + m, mid)
        elif hi - x < m:
            x = max(hi - m, mid)
        fx = f(x)
        if fx == 0.0:
            a = b = x
            fa = fb = 0.0
            break
        if (fx > 0) == (fa > 0):
            if side == 1:
                fb /= 2
            a, fa, side = x, fx, 1
        else:
            if side == -1:
                fa /= 2
            b, fb, side = x, fx, -1
    t = a if abs(fa) <= abs(fb) else b
    return t, seen[t].real
