"""Closed-loop poles within double precision's reach of the unit circle, decided in mpmath (issue 34).

The argument principle (optim.stability.closed_loop.count_outside) counts the closed-loop poles outside the unit
circle from the winding of the return difference F = 1 + C·G, evaluated in double precision.  A pole at |z| − 1 = r
makes arg F swing by ±π over an arc of width ~|r| around its foot θ_f on the circle, and the sign of r (inside or
outside) is read from F there.  Linearised at the foot, F(θ) ≈ F_θ·((θ − θ_f) − j·r), so

    r = Im(F/F_θ) at the foot,   and an error η of F there moves that reading by up to η/|F_θ|.

η is not small where it matters: F near a lightly damped cable mode inherits the rounding of the mode's pole
(the double matrix exponential places it to ~1e-15), and at a critical gain checked at K_cr·(1 ± 1e-6) the crossing
pole may sit 2e-17 off the circle (docs/properties_analysis.md, "Cable fast path").  Double precision then reads the
count from rounding.

So every closed-loop pole that the double samples place within :data:`NEAR_CIRCLE` of the circle is examined again
with ``precise`` (F in mpmath, from a plant sampled in mpmath): Newton along the circle gives its foot and r in
50 digits, and F's double error η is measured there (the double F against the mpmath F at the same θ).  Double
precision's reach is :data:`REACH_SAFETY`·η/|F_θ| plus the spacing of doubles at θ (a swing narrower than that
cannot be sampled).  A pole beyond the reach is on the side the double winding saw; one within it has the double
winding over an arc around its foot replaced by the winding in mpmath, sampled geometrically towards the foot and
refined by bisection.  A pole within mpmath's own rounding of the circle is not decided (the count is None, with
the reason).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import mpmath as mp
import numpy as np

__all__ = ["NEAR_CIRCLE", "REACH_SAFETY", "Correction", "precise_correction"]

_EPS = float(np.finfo(float).eps)

#: closed-loop poles the double samples place within this of the unit circle [|z| − 1] are examined in mpmath
NEAR_CIRCLE = 1e-8
#: the double winding stands for a pole that lies beyond this many times F's measured error over |F_θ|
REACH_SAFETY = 10.0
#: mpmath evaluations of F one count may spend on its arcs before it says the count is not resolved
MAX_PRECISE_EVALUATIONS = 3000
#: the largest turn of arg F between neighbouring mpmath samples after refinement [rad]
_TURN = math.pi / 3
#: an arc's ends must agree with mpmath's arg F within this [rad] (the double sum over the arc is replaced there)
_END_ARG = 0.02


@dataclass(frozen=True)
class Correction:
    """What the mpmath arcs change in the double winding over one segment set."""

    turn: float
    """radians to add to the double Δarg F over the upper half circle."""
    evaluations: int
    """mpmath evaluations of F."""
    note: str | None
    """the poles decided in mpmath: where and how far off the circle (None: none needed)."""
    reason: str | None = None
    """why the count is not resolved (then ``turn`` is meaningless)."""


def _near_poles(poles: np.ndarray) -> np.ndarray:
    """The open-loop poles within 0.1 of the unit circle (F's poles that shape it there)."""
    poles = np.asarray(poles, dtype=complex)
    return poles[np.abs(np.abs(poles) - 1.0) < 0.1]


def _cleared(theta: np.ndarray, f: np.ndarray, poles: np.ndarray) -> np.ndarray:
    """H = F·Π(z − p) over the open-loop poles near the circle: the closed-loop poles are its zeros, and a lightly
    damped open-loop pole no longer makes a minimum of |F| beside it look like one."""
    z = np.exp(1j * theta)
    out = np.asarray(f, dtype=complex).copy()
    for p in poles:
        out = out * (z - p)
    return out


def _candidates(th: np.ndarray, vals: np.ndarray, hd: Callable) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(θ_f, |r|, |H_θ|) of the local minima of |H| whose linearised zero lies within NEAR_CIRCLE of the circle
    (double estimates: the secant through the neighbours, one Newton step)."""
    n = th.size
    none = np.zeros(0)
    if n < 2:
        return none, none, none
    a = np.abs(vals)
    # interior minima, and θ = π (a real pole near z = −1); not a segment's other ends: those are z = 1's and an
    # undamped mode's indentations, whose poles the count takes from the structure
    left = np.concatenate([[False], a[1:] <= a[:-1]])
    right = np.concatenate([a[:-1] <= a[1:], [bool(th[-1] == math.pi)]])
    i = np.nonzero(left & right)[0]
    lo, hi = np.maximum(i - 1, 0), np.minimum(i + 1, n - 1)
    slope = (vals[hi] - vals[lo]) / (th[hi] - th[lo])
    ok = np.isfinite(slope) & (slope != 0)
    i, lo, hi, slope = i[ok], lo[ok], hi[ok], slope[ok]
    if i.size == 0:
        return none, none, none
    step = vals[i] / slope
    foot = np.clip(th[i] - step.real, th[lo], th[hi])
    r = np.minimum(np.abs(step.imag), np.abs((hd(foot) / slope).imag))
    keep = r < NEAR_CIRCLE
    return foot[keep], r[keep], np.abs(slope[keep])


def _foot(precise: Callable, theta: float, digits: int) -> tuple[mp.mpf, mp.mpf, mp.mpc, mp.mpc, int] | None:
    """(θ_f, r, F(θ_f), F_θ(θ_f), evaluations): Newton along the circle to the foot of the nearest zero of F, in
    mpmath; None when it does not settle."""
    th = mp.mpf(theta)
    h = mp.mpf(10) ** (-(digits // 2 + 5))
    tol = mp.mpf(10) ** (-(digits - 5))
    evals = 0
    for _ in range(40):
        f, fh = precise(th), precise(th + h)
        evals += 2
        slope = (fh - f) / h
        if slope == 0:
            return None
        q = f / slope
        new = th - mp.re(q)
        # stay inside (0, π]: a step past an end goes half way to it (z = 1 is a pole of F)
        th = th / 2 if new <= 0 else (th + mp.pi) / 2 if new > mp.pi else new
        if abs(mp.re(q)) <= max(tol * abs(th), mp.mpf("1e-6") * abs(mp.im(q))):
            f = precise(th)
            evals += 1
            return th, mp.im(f / slope), f, slope, evals
    return None


def _winding(precise: Callable, pts: list, budget: int) -> tuple[float | None, int]:
    """Δarg F over the sorted mpmath points, bisecting every step that turns by more than _TURN; None when the
    budget of evaluations runs out first."""
    vals = [precise(p) for p in pts]
    evals = len(vals)
    while True:
        steps = [float(mp.arg(vals[k + 1] / vals[k])) for k in range(len(vals) - 1)]
        bad = [k for k, s in enumerate(steps) if abs(s) > _TURN]
        if not bad:
            return float(sum(steps)), evals
        if evals + len(bad) > budget:
            return None, evals
        for k in reversed(bad):
            mid = (pts[k] + pts[k + 1]) / 2
            if mid == pts[k] or mid == pts[k + 1]:
                return None, evals
            pts.insert(k + 1, mid)
            vals.insert(k + 1, precise(mid))
        evals += len(bad)


def precise_correction(segments: list[tuple[np.ndarray, np.ndarray]], ret_diff: Callable, precise: Callable,
                       digits: int, unresolved: list[float], poles: np.ndarray,
                       rounding: Callable | None = None) -> Correction:
    """The mpmath arcs for every closed-loop pole within double precision's reach of the circle (module docstring).

    ``segments``: the double winding's samples (θ, F) per arc of the upper half circle; ``ret_diff``: F in doubles;
    ``precise``: F(θ) in mpmath (θ an mpf, the caller's ``digits``); ``unresolved``: θ of the intervals that double
    precision could not refine (their arc is always taken in mpmath); ``poles``: the open-loop poles (F's).  The
    poles are located on H = F·Π(z − p) (:func:`_cleared`), the count's arcs on F itself.  ``rounding(θ)``: an a-priori
    bound on the double F's error (the plant's matrices and their solve rounded, normwise): a pole farther off the
    circle than three times the reach it gives is left to the double winding without an mpmath evaluation."""
    near = _near_poles(poles)
    try:
        return _with_poles(segments, ret_diff, precise, digits, unresolved, near, rounding)
    except ZeroDivisionError:                    # mpmath's solve on a pole of the plant
        return Correction(0.0, 0, None, f"the return difference in {digits}-digit mpmath met a pole of the plant")


def _with_poles(segments, ret_diff, precise, digits, unresolved, near, rounding) -> Correction:
    with mp.workdps(digits + 10):
        mp_poles = [mp.mpc(complex(p)) for p in near]

        def hd(theta: np.ndarray) -> np.ndarray:
            return _cleared(theta, ret_diff(theta), near)

        def hp(theta):
            out = precise(theta)
            z = mp.expj(theta)
            for p in mp_poles:
                out *= z - p
            return out
        return _correct(segments, ret_diff, hd, hp, precise, digits, unresolved, near, rounding)


def _correct(segments, ret_diff, hd, hp, precise, digits, unresolved, near, rounding) -> Correction:
    turn, evals, notes = 0.0, 0, []
    for th, vals in segments:
        forced = [u for u in unresolved if th[0] <= u <= th[-1]]
        arcs: list[list] = []           # [lo index, hi index, [(θ_f, r), ...]]
        feet, r_d, slope_d = _candidates(th, _cleared(th, vals, near), hd)
        if rounding is not None and feet.size:
            eta_d = rounding(feet) * np.prod(np.abs(np.exp(1j * feet)[:, None] - near[None, :]), axis=1)
            clear = r_d > 3.0 * (REACH_SAFETY * eta_d / slope_d + 8.0 * _EPS * feet)
            feet = feet[~clear]
        seen: list[tuple[float, float]] = []      # (θ_f, reach) of the poles examined: one look per pole
        for c in [float(x) for x in feet] + forced:
            if c not in forced and any(abs(c - x0) <= 1e3 * r0 for x0, r0 in seen):
                continue
            found = _foot(hp, c, digits)
            if found is None:
                return Correction(0.0, evals, None, f"Newton in {digits} digits found no foot of the closed-loop "
                                                    f"pole near θ = {c:.9g}")
            foot, r, f, slope, n = found
            evals += n + 1
            x = float(foot)
            evals += 2
            eta = max(abs(complex(hd(np.array([y]))[0]) - complex(hp(mp.mpf(y)))) for y in (x, c))
            # the size of H's terms: F = 1 + C·G times Π|z − p| (the floor of any rounding of H)
            terms = (1.0 + abs(complex(ret_diff(np.array([x]))[0]) - 1.0)) * float(np.prod(np.abs(np.exp(1j * x) - near)))
            eta = max(eta, _EPS * terms)
            reach = REACH_SAFETY * eta / float(abs(slope)) + 8.0 * _EPS * abs(x)
            again = any(abs(x - x0) <= 1e-3 * max(r0, reach) for x0, r0 in seen)
            if again and c not in forced:
                continue                # another minimum of the same pole
            seen.append((x, max(reach, float(abs(r)))))
            if abs(r) >= reach and c not in forced:
                continue                # the double winding saw this pole on its side
            floor = mp.mpf(10) ** (-(digits - 8)) * terms / abs(slope)
            if abs(r) <= floor:
                return Correction(0.0, evals, None, f"a closed-loop pole lies within {digits}-digit rounding of the "
                                                    f"unit circle at θ = {x:.9g}")
            w = 1e3 * reach
            lo = max(int(np.searchsorted(th, min(x, c) - w)) - 1, 0)
            hi = min(int(np.searchsorted(th, max(x, c) + w)), th.size - 1)
            arcs.append([lo, hi, [(foot, r, reach, w)]])
            if not again:
                notes.append(f"a pole {float(r):+.1e} off the circle at θ = {x:.9g}, below double precision's reach "
                             f"({reach:.1e})")
        if not arcs:
            continue
        arcs.sort(key=lambda a: a[0])
        merged = [arcs[0]]
        for a in arcs[1:]:
            if a[0] <= merged[-1][1]:
                merged[-1][1] = max(merged[-1][1], a[1])
                merged[-1][2] += a[2]
            else:
                merged.append(a)
        for lo, hi, feet in merged:
            got = _arc(th, vals, precise, lo, hi, feet, digits, MAX_PRECISE_EVALUATIONS - evals)
            evals += got[1]
            if got[0] is None:
                return Correction(0.0, evals, None, got[2])
            turn += got[0]
    note = None
    if notes:
        note = f"{'; '.join(notes)}: decided in {digits}-digit mpmath (optim.stability.circle_reach)"
    return Correction(turn, evals, note)


def _arc(th, vals, precise, lo, hi, feet, digits, budget) -> tuple[float | None, int, str | None]:
    """(mpmath Δarg − double Δarg over th[lo..hi], evaluations, reason): the arc widened ×30 until both ends agree
    with mpmath."""
    evals = 0
    for _ in range(5):
        ends = [precise(mp.mpf(float(th[lo]))), precise(mp.mpf(float(th[hi])))]
        evals += 2
        if all(abs(float(mp.arg(mp.mpc(complex(vals[k])) / e))) < _END_ARG for k, e in zip((lo, hi), ends)):
            break
        if lo == 0 and hi == th.size - 1:
            return None, evals, "double precision does not resolve arg F anywhere near the pole"
        w = 30.0 * max(float(th[hi] - th[lo]), 1e-300)
        mid = 0.5 * (float(th[lo]) + float(th[hi]))
        lo = max(int(np.searchsorted(th, mid - w)) - 1, 0)
        hi = min(int(np.searchsorted(th, mid + w)), th.size - 1)
    else:
        return None, evals, "double precision does not resolve arg F at the ends of the pole's arc"
    a, b = mp.mpf(float(th[lo])), mp.mpf(float(th[hi]))
    idx = np.arange(lo, hi + 1)
    if idx.size > 200:
        idx = np.unique(np.concatenate([np.linspace(lo, hi, 200).astype(int), [lo, hi]]))
    pts = {mp.mpf(float(th[k])) for k in idx}
    for foot, r, _reach, _w in feet:
        near = max(abs(r) * mp.mpf("0.01"), mp.mpf(10) ** (-(digits - 8)) * max(abs(foot), 1))
        span = max(foot - a, b - foot)
        if span <= near:
            continue
        k = int(math.ceil(math.log2(float(span / near)))) + 1
        for j in range(k + 1):
            s = near * mp.mpf(2) ** j
            for p in (foot - s, foot + s):
                if a < p < b:
                    pts.add(p)
        if a < foot < b:
            pts.add(foot)
    got, n = _winding(precise, sorted(pts), budget - evals)
    evals += n
    if got is None:
        return None, evals, f"arg F over the pole's arc in {digits}-digit mpmath not resolved within " \
                            f"{MAX_PRECISE_EVALUATIONS} evaluations"
    double = float(np.sum(np.angle(vals[lo + 1:hi + 1] / vals[lo:hi])))
    return got - double, evals, None
