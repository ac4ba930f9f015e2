"""The exact K_f,cr(θ_c) over the cutoff band, with its discontinuities bracketed (the search of optim/transparency/inertia.py).

K_f,cr(θ_c) is the smallest gain over the loop's phase crossovers.  Each crossover moves smoothly with the
cutoff, but a pair can appear (or vanish) tangentially: Im h̃ touches zero and splits into two roots.  When the
new pair's gain is below the others, K_f,cr jumps there.  No local crossover condition describes a jump, so an
NLP started on one side never sees the other.  A scan whose samples straddle the jump can also miss the higher
side, which may be the band's maximum: the issue-17 cable device gave 116.15 at a scan point, but 118.13 holds
just past a jump between two scan points.

The profile therefore:

1. samples the Pareto scan plus the geometric midpoints (``_DENSITY`` samples per Pareto interval);
2. compares the crossover structure (how many crossovers each grasp's loop has) of neighbouring samples; where
   it differs, bisects the structure (recursively, for several changes in one interval) to a relative width
   1e-4, and to ``JUMP_RTOL`` = 1e-9 next to a sample within 10 % of the best, and keeps the samples on both
   sides of each change (a target's boundary at a jump is then bisected on the exact verdict to a few ulp);
3. splits the samples into *pieces* of constant structure, inside which K_f,cr is continuous.  Each piece's
   local maxima are refined with the crossover NLP inside the piece (``refine``); a piece's edge
   next to a jump is a sample of its own, so the higher side of every jump is examined.

Changes that cancel within one interval of the base scan (a pair born and dying between two samples) are not
seen; the property test of tests/optim/transparency/test_inertia_band.py measures what a dense scan still finds beyond the
profile (the tolerance is stated there).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
from scipy.optimize import brentq

from optim.transparency.inertia_nlp import solve_crossover_nlp

__all__ = ["BandProfile", "BandAnswer", "band_profile", "refine_peaks", "maximise", "highest_feasible",
           "refine", "bisect_verdict", "JUMP_RTOL"]

_MAX_EXCHANGE_ROUNDS = 6

_DENSITY = 2            # base samples per interval of the Pareto scan
JUMP_RTOL = 1e-9        # relative width in θ_c to which a change of crossover structure is bracketed ...
_COARSE_RTOL = 1e-4     # ... first to this, then to JUMP_RTOL where the band's maximum may be
_MAX_CHANGES = 16       # structure changes located per base interval (beyond: the rest are left unsplit)
_PEAK_FRACTION = 0.9    # local maxima refined: those within this fraction of the best sample (or the target)
_MAX_PEAKS = 4          # ... at most this many, best first


@dataclass(frozen=True)
class BandProfile:
    """Samples of the exact K_f,cr over the band, sorted by cutoff angle."""

    thetas: np.ndarray
    """θ_c [rad/sample] of each sample (at the reference sample time)."""
    kcrs: np.ndarray
    """exact K_f,cr (worst grasp or scenario) at each sample [dimensionless]."""
    pieces: np.ndarray
    """piece index of each sample: equal for neighbours of the same crossover structure (K_f,cr continuous)."""
    jumps: tuple[tuple[float, float], ...]
    """(θ below, θ above) of every located change of crossover structure, width ≤ JUMP_RTOL·θ."""

    def piece_bounds(self, i: int) -> tuple[float, float]:
        """The neighbouring samples of sample i within its piece (i itself at a piece's edge)."""
        lo = i - 1 if i > 0 and self.pieces[i - 1] == self.pieces[i] else i
        hi = i + 1 if i + 1 < len(self.thetas) and self.pieces[i + 1] == self.pieces[i] else i
        return float(self.thetas[lo]), float(self.thetas[hi])

    def local_maxima(self) -> list[int]:
        """Samples not below either neighbour of their own piece, best first (a piece's edge next to a jump
        counts as a maximum when K_f,cr rises towards it)."""
        k, p, n, out = self.kcrs, self.pieces, len(self.kcrs), []
        for i in range(n):
            left = k[i - 1] if i > 0 and p[i - 1] == p[i] else -math.inf
            right = k[i + 1] if i + 1 < n and p[i + 1] == p[i] else -math.inf
            if k[i] >= left and k[i] >= right:
                out.append(i)
        return sorted(out, key=lambda i: -k[i])

    def with_points(self, points: list[tuple[float, float, int]]) -> "BandProfile":
        """The profile with extra (θ, K_f,cr, piece) samples (refined maxima) merged in."""
        if not points:
            return self
        th = np.concatenate([self.thetas, [p[0] for p in points]])
        order = np.argsort(th, kind="stable")
        return BandProfile(th[order], np.concatenate([self.kcrs, [p[1] for p in points]])[order],
                           np.concatenate([self.pieces, [p[2] for p in points]])[order], self.jumps)


def band_profile(loop, scan_thetas: np.ndarray) -> BandProfile:
    """The profile of ``loop`` (optim.transparency.feedforward_loop.FeedforwardLoop: exact(θ) and structure(θ)) over the scan's band.

    Every change is first bracketed to _COARSE_RTOL; those next to a sample within _PEAK_FRACTION of the best
    (where the band's maximum may sit, at the higher side of a jump) are then narrowed to JUMP_RTOL."""
    scan = np.asarray(scan_thetas, dtype=float)
    base = [float(scan[0])]
    for a, b in zip(scan[:-1], scan[1:]):
        base += [float(a * (b / a) ** (j / _DENSITY)) for j in range(1, _DENSITY)] + [float(b)]
    brackets = {}                                   # base interval → its changes
    for a, b in zip(base[:-1], base[1:]):
        brackets[(a, b)] = _changes(loop.structure, a, b, _COARSE_RTOL)
    top = max(loop.exact(t)[0] for t in base + [t for c in brackets.values() for pair in c for t in pair])
    thetas, jumps = [base[0]], []
    for (_, b), changes in brackets.items():
        for lo, hi in changes:
            if max(loop.exact(lo)[0], loop.exact(hi)[0]) >= _PEAK_FRACTION * top:
                lo, hi = _changes(loop.structure, lo, hi, JUMP_RTOL)[0]
            thetas += [lo, hi]
            jumps.append((lo, hi))
        thetas.append(b)
    thetas = np.array(thetas)
    structures = [loop.structure(t) for t in thetas]
    pieces = np.cumsum([0] + [int(s != r) for s, r in zip(structures[:-1], structures[1:])])
    kcrs = np.array([loop.exact(t)[0] for t in thetas])
    return BandProfile(thetas, kcrs, pieces, tuple(jumps))


def _changes(structure: Callable[[float], tuple], a: float, b: float, rtol: float) -> list[tuple[float, float]]:
    """Brackets (lo, hi), hi − lo ≤ rtol·hi, of the structure changes between a and b, left to right."""
    out: list[tuple[float, float]] = []
    while structure(a) != structure(b) and len(out) < _MAX_CHANGES:
        s_a, lo, hi = structure(a), a, b
        while hi - lo > rtol * hi:
            mid = 0.5 * (lo + hi)
            if structure(mid) == s_a:
                lo = mid
            else:
                hi = mid
        out.append((lo, hi))
        a = hi
    return out


def refine_peaks(loop, profile: BandProfile, local: Callable[[float, tuple[float, float]], float | None],
                 lo_k: float, hi_k: float = math.inf) -> tuple[BandProfile, list[float]]:
    """The profile with its local maxima of K_f,cr in [lo_k, hi_k) refined inside their pieces (at most
    _MAX_PEAKS, best first), and the start angles whose NLP failed.

    ``local(θ_start, (θ_lo, θ_hi))`` is the crossover NLP (returns θ or None); a refined point joins only when
    its exact K_f,cr beats its start.
    """
    extra, failed = [], []
    peaks = [i for i in profile.local_maxima() if lo_k <= profile.kcrs[i] < hi_k][:_MAX_PEAKS]
    for i in peaks:
        lo, hi = profile.piece_bounds(i)
        if not lo < hi:
            continue
        theta = local(float(profile.thetas[i]), (lo, hi))
        if theta is None:
            failed.append(float(profile.thetas[i]))
            continue
        k = loop.exact(theta)[0]
        if k > profile.kcrs[i] and theta not in profile.thetas:
            extra.append((theta, k, int(profile.pieces[i])))
    return profile.with_points(extra), failed


@dataclass(frozen=True)
class BandAnswer:
    theta: float | None
    """the chosen cutoff angle [rad/sample]; None: infeasible (target) or failed (see ``failed``)."""
    profile: BandProfile
    """the profile with its refined maxima: its largest K_f,cr is the band's maximum."""
    failed: bool = False
    """the crossover NLP did not converge where it decides the answer."""
    stats: dict[str, Any] = field(default_factory=dict)
    """the statistics of the solve (or exact step) that decided the answer: return_status, exchange_rounds, ..."""

    @property
    def best(self) -> tuple[float, float]:
        """(θ, K_f,cr) of the largest K_f,cr found over the band."""
        j = int(np.argmax(self.profile.kcrs))
        return float(self.profile.thetas[j]), float(self.profile.kcrs[j])


def _nlp(loop, modal, log_rho: float):
    """The max-gain NLP as ``refine_peaks`` wants it, keeping each solve's statistics by its answer."""
    stats: dict = {}

    def local(theta0: float, bounds: tuple[float, float]) -> float | None:
        sub: dict = {}
        theta = refine(loop, modal, log_rho, theta0, bounds, "max_gain", 0.0, sub)
        stats[theta0 if theta is None else theta] = sub
        return theta
    return local, stats


def maximise(loop, profile: BandProfile, modal, log_rho: float) -> BandAnswer:
    """The cutoff of the largest K_f,cr: every promising local maximum of every piece refined."""
    local, stats = _nlp(loop, modal, log_rho)
    top = float(np.max(profile.kcrs))
    start = float(profile.thetas[int(np.argmax(profile.kcrs))])
    out, failed = refine_peaks(loop, profile, local, _PEAK_FRACTION * top)
    theta, _ = BandAnswer(None, out).best
    if theta == start and start in failed:
        return BandAnswer(None, out, failed=True, stats=dict(stats[start]))
    return BandAnswer(theta, out, stats=dict(stats.get(theta, {
        "return_status": "sample kept (a piece's edge, or no solve beat it)", "exchange_rounds": 0})))


def highest_feasible(loop, profile: BandProfile, modal, log_rho: float, need: float) -> BandAnswer:
    """The highest cutoff with K_f,cr ≥ ``need`` (theta None when no cutoff reaches it: then the profile's
    largest K_f,cr is the band's maximum, refined)."""
    local, _ = _nlp(loop, modal, log_rho)
    info: dict[str, Any] = {}       # this answer's statistics (BandAnswer.stats)
    top = float(np.max(profile.kcrs))
    # only maxima that could reach the need are refined; with none feasible, the best (the reason's maximum)
    lo_k, hi_k = (_PEAK_FRACTION * need, need) if top >= need else (_PEAK_FRACTION * top, math.inf)
    out, _ = refine_peaks(loop, profile, local, lo_k, hi_k)
    ok = np.nonzero(out.kcrs >= need)[0]
    if ok.size == 0:
        return BandAnswer(None, out)
    i = int(ok[-1])
    if i == len(out.thetas) - 1:
        return BandAnswer(float(out.thetas[-1]), out, stats={"return_status": "upper cutoff bound feasible (exact)",
                                                              "exchange_rounds": 0})
    a, b = float(out.thetas[i]), float(out.thetas[i + 1])
    if out.pieces[i] != out.pieces[i + 1]:
        # the boundary is a change of crossover structure (a jump of K_f,cr): no crossover condition
        # describes it, so the exact verdict is bisected
        stats = {"return_status": "exact bisection (crossover branches change in the bracket)", "exchange_rounds": 0}
        theta = bisect_verdict(lambda th: loop.exact(th)[0] >= need, a, b)
        # 1e-12 back from the jump: the cutoff in Hz, converted back to an angle, must not round across it
        back = max(a, theta * (1 - 1e-12))
        return BandAnswer(back if loop.exact(back)[0] >= need else theta, out, stats=stats)
    theta = refine(loop, modal, log_rho, a, (a, b), "max_cutoff", math.log(need) - log_rho, info)
    if theta is None:
        return BandAnswer(None, out, failed=True, stats=info)
    theta = _exact_boundary(lambda th: math.log(loop.exact(th)[0] / need), a, theta, info)
    return BandAnswer(theta, out, stats=info)


def _merge(tracked: list[tuple[int, float]], new: list[tuple[int, float]]) -> list[tuple[int, float]]:
    out = list(tracked)
    for j, a in new:
        if not any(j == jj and abs(a - aa) <= 1e-6 * a for jj, aa in out):
            out.append((j, a))
    return out


def refine(loop, modal, log_rho: float, t0: float, bounds: tuple[float, float],
           objective: str, y_fixed: float, info: dict) -> float | None:
    """Exchange method: local NLP solves until the exact analysis agrees; returns θ_c or None (failed)."""
    k0, _, _, tracked = loop.exact(t0)
    y0 = math.log(k0) - log_rho if objective == "max_gain" else y_fixed
    for rounds in range(1, _MAX_EXCHANGE_ROUNDS + 1):
        res = solve_crossover_nlp(modal, tracked, loop.order, log_rho, t0, bounds, y0, objective, y_fixed,
                                  cutoff_scales=loop.cutoff_scales)
        info.update(return_status=res.return_status, exchange_rounds=rounds,
                    tracked_crossovers=len(tracked))
        if not res.success:
            return None
        # Ipopt may relax a bound by ~1e-8 (bound_relax_factor): the band is a hard limit.
        theta = min(max(res.cutoff_angle, bounds[0]), bounds[1])
        kcr, _, _, found = loop.exact(theta)
        gain = math.exp(res.log_gain + log_rho)
        if gain <= kcr * (1 + 1e-8):
            return theta
        tracked = _merge(tracked, found)
    info["return_status"] = "exchange did not settle"
    return None


def bisect_verdict(feasible_at: Callable[[float], bool], good: float, bad: float) -> float:
    """The last feasible θ before ``bad`` to a few ulp (the exact verdict decides each step)."""
    while bad - good > 8 * np.finfo(float).eps * bad:
        mid = 0.5 * (good + bad)
        if feasible_at(mid):
            good = mid
        else:
            bad = mid
    return good


def _exact_boundary(margin, feasible: float, theta: float, info: dict) -> float:
    """θ itself when the exact margin holds there; else the exact boundary between the
    last feasible sample and θ (Brent on the exact log-margin), on its feasible side."""
    if margin(theta) >= 0.0:
        return theta
    root = brentq(margin, feasible, theta, xtol=1e-15, rtol=4 * np.finfo(float).eps)
    for _ in range(60):
        if margin(root) >= 0.0:
            break
        root = feasible + (root - feasible) * (1 - 1e-12)
    info["polished"] = "exact bracketing (Brent) of the margin boundary"
    return root
