"""Passivity of the virtual wall (Colgate–Schenkel) with the loop delay (ARCHITECTURE.md "Passivity").

Eq. 3 of the chapter, b > KT/2 + B, holds only without delay.  With d whole
samples of delay the same theorem applied to z^(−d)·C(z) gives

    b > P(θ) = (K·T/2)·s_d(θ) − B·cos((d+1)θ)   for every θ ∈ (0, π],
    s_d(θ) = sin((d+½)θ)/sin(θ/2) = 1 + 2·Σ_{k=1..d} cos(kθ)   (Dirichlet kernel, 2d+1 at θ → 0),

which is eq. 3 at d = 0 and b > K(T/2 + t_d) at B = 0.  A fractional delay is
rounded *up* to the next whole sample: conservative, and every answer says so.

P is linear in (K, B) for each θ, so for a given B the passive stiffnesses form
an interval: K < (b + B·c)/((T/2)·s) where s > 0 and K > (b + B·c)/((T/2)·s)
where s < 0.  The passive set is strict (b > P), so the largest passive K is a
supremum: every K below it is passive.

Dimensionless form (Table 1): δ > (α/2)·s_d(θ) − β·cos((d+1)θ).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from models.device import Device
from models.discretize import split_delay
from optim.errors import InputError
from optim.golden import golden_minimum
from optim.stability.passivity_kernel import (
    SUP_TOL,
    best_of_rows,
    needs_python,
    polish_max,
    prefix_samples,
    sup_bound,
)

__all__ = ["PassivityCheck", "PassiveStiffness", "passivity_samples", "kernel", "passivity_margin",
           "is_passive", "max_passive_stiffness", "largest_passive_stiffness", "passive_alpha_on_grid",
           "batch_required_damping"]

_EPS = float(np.finfo(float).eps)
#: _p_slopes_at takes the closed form's derivatives above this many delay samples (where (d + ½)θ ≥ 1)
_SUM_TERMS_MIN = 4
_GOLDEN_STEPS = 80         # a bracket of 2 grid steps shrinks by 0.618⁸⁰ ≈ 2e-17: θ to the last bit


@dataclass(frozen=True)
class PassivityCheck:
    """Whether (K, B) is passive on this device."""

    passive: bool
    required_damping: float
    """sup over θ of P(θ) [N·s/m], bounded from above: the physical damping passivity needs (passive iff b exceeds
    it).  With delay (and B > 0) a proven upper bound (optim.stability.passivity_kernel.sup_bound): never below the
    sup, at most ``error_bound`` above it."""
    delay_samples_used: int
    """whole samples of delay used (a fractional delay is rounded up)."""
    conservative: bool
    """True when a fractional delay was rounded up to the next whole sample."""
    worst_angle: float | None = None
    """θ = ωT [rad] where P(θ) is largest (the largest value met)."""
    error_bound: float = 0.0
    """[N·s/m]: required_damping − sup P lies in [0, error_bound] (sup_bound: 1e-13 of P's scale hk·(2d+1) + B
    plus twice its rounding bound); the closed forms (no delay, or B = 0) are the formula in floating point,
    within rounding (≤ 1 ulp) of it, and say 0."""


@dataclass(frozen=True)
class PassiveStiffness:
    """Largest passive stiffness for one virtual damping B."""

    stiffness: float
    """sup of passive K [N/m]; 0 with a reason when no K > 0 is passive."""
    damping: float
    """B [N·s/m] the answer is for."""
    worst_angle: float | None
    """θ = ωT [rad] where the passivity bound binds (0 means the limit θ → 0⁺)."""
    delay_samples_used: int
    conservative: bool
    reason: str | None = None


def passivity_samples(device: Device) -> tuple[int, bool]:
    """(whole samples of delay used by the passivity test, whether a fraction was rounded up)."""
    d, f = split_delay(device.delay_samples)
    return (d + 1, True) if f > 0 else (d, False)


def kernel(theta: np.ndarray, d: int) -> tuple[np.ndarray, np.ndarray]:
    """(s_d(θ), cos((d+1)θ)); s_d through its closed form, exactly 2d+1 at θ = 0."""
    theta = np.asarray(theta, dtype=float)
    half = np.sin(theta / 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(half != 0.0, np.sin((d + 0.5) * theta) / np.where(half != 0.0, half, 1.0), 2 * d + 1.0)
    return s, np.cos((d + 1) * theta)


def _grid(d: int) -> np.ndarray:
    # s_d has d zeros on (0, π); 64 samples per lobe, θ = 0 (the limit) and θ = π included.
    return np.linspace(0.0, math.pi, 64 * (d + 1) + 257)


def _refine_min(fun, grid: np.ndarray, values: np.ndarray, idx: int) -> tuple[float, float]:
    lo, hi = grid[max(idx - 1, 0)], grid[min(idx + 1, grid.size - 1)]
    best_t, best_v = float(grid[idx]), float(values[idx])
    if hi > lo:
        # fun is +inf where the bound does not apply (s_d of the wrong sign); the bounded search's parabolic step
        # then does inf − inf and falls back to golden section, which is right, but numpy warns (an error under the
        # service's errstate and the tests' warning filter: a passive-band design at 70.5 samples of delay)
        with np.errstate(invalid="ignore", over="ignore"):
            res = minimize_scalar(lambda t: float(fun(np.array([t]))[0]), bounds=(lo, hi), method="bounded",
                                  options={"xatol": 1e-14})
        if res.fun < best_v:
            best_t, best_v = float(res.x), float(res.fun)
    return best_t, best_v


def _p_slopes(theta: np.ndarray, d: int, hk: float, damping: float) -> tuple[np.ndarray, np.ndarray]:
    """(P'(θ), P''(θ)) of P = hk·s_d − B·cos((d+1)θ), s_d = 1 + 2·Σ_{k≤d} cos(kθ): the sum form, exact at 0 and π."""
    k = np.arange(1, d + 1, dtype=float)
    kt = theta[:, None] * k[None, :]
    e = d + 1.0
    ds = -2.0 * (np.sin(kt) @ k)
    dds = -2.0 * (np.cos(kt) @ (k * k))
    return hk * ds + damping * e * np.sin(e * theta), hk * dds + damping * e * e * np.cos(e * theta)


def _p_slopes_at(t: float, d: int, hk: float, damping: float) -> tuple[float, float]:
    """``_p_slopes`` at one θ: where d > 4 and (d + ½)θ ≥ 1 (the sums' 5+ terms cost more: 2 sines a term), the derivatives of the closed form s_d = sin(Nθ)/sin(θ/2), N = d + ½ (from
    s_d·sin(θ/2) = sin(Nθ): s' = (N cos Nθ − ½ s cos(θ/2))/sin(θ/2), s'' = (−N² sin Nθ − s' cos(θ/2) + ¼ s sin(θ/2))
    /sin(θ/2)), whose rounding error ≈ ε·N/sin(θ/2) stays ≈ ε relative to s' there (|s'| ≳ N³θ in the main lobe,
    ≈ N²/sin(θ/2) past it); below, the sums (the closed form's 0/0 at θ = 0), in plain floats up to 32 terms (array
    calls cost more there), in numpy beyond.  The slopes only steer ``_polish_max``'s Newton to P's maximum, where
    P is flat: its value, the answer, keeps its bits (old vs new on 2,000 random devices, issue 20)."""
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
        if d > 32:
            fa, fpa = _p_slopes(np.array([t]), d, hk, damping)
            return float(fa[0]), float(fpa[0])
    ds = dds = 0.0
    for k in range(1, d + 1):
        ds += k * math.sin(k * t)
        dds += k * k * math.cos(k * t)
    e = d + 1.0
    return hk * (-2.0 * ds) + damping * e * math.sin(e * t), hk * (-2.0 * dds) + damping * e * e * math.cos(e * t)


def _polish_max(d: int, hk: float, damping: float, a: float, b: float, t: float) -> float:
    """The local maximum of P inside [a, b] (from the start ``t``): Newton on P' = 0 kept inside the bracket by
    bisection.  A bracket that holds no interior maximum (P' does not go from + to −) returns nan."""
    # the sign of P' just inside each end: P'(0) = P'(π) = 0 by symmetry, so there the curvature decides
    fa, ca = _p_slopes_at(a, d, hk, damping)
    fb, cb = _p_slopes_at(b, d, hk, damping)
    if not ((ca > 0 if a == 0.0 else fa > 0) and (cb > 0 if b == math.pi else fb < 0)):
        return math.nan
    eps4 = 4 * _EPS
    for _ in range(100):
        f, fp = _p_slopes_at(t, d, hk, damping)
        if f == 0.0:
            break
        if f > 0:
            a = t
        else:
            b = t
        if fp < 0:
            step = f / fp
            if abs(step) <= eps4 * abs(t):   # converged: the step is below rounding (t may sit on a bracket end)
                break
            newton = t - step
            t = newton if a < newton < b else 0.5 * (a + b)
        else:
            t = 0.5 * (a + b)
        if b - a <= eps4 * b:
            break
    return t


#: where the general path puts the maximum of a constant P (d = 0, B = 0): the first of np.argpartition's top three
_FLAT_WORST_ANGLE = float(_grid(0)[np.argpartition(np.zeros(_grid(0).size), 2)[0]])


def _best_of_rows(d: int, hk: float, damping: float, grid: np.ndarray, vals: np.ndarray, top: list[int],
                  v_pi: float) -> tuple[float, float]:
    """passivity_kernel.best_of_rows in Python, for rows whose bracket needs _p_slopes_at's numpy sums (d > 32 and
    (d + ½)θ < 1): (sup P, its θ)."""
    last = grid.size - 1
    cand_t = [float(grid[i]) for i in top]
    cand_v = [float(vals[i]) for i in top]
    refined_t: list[float] = []
    refined_v: list[float] = []
    for row, i in enumerate(top):   # three rows: plain floats beat array bookkeeping
        i_lo, i_hi = max(i - 1, 0), min(i + 1, last)
        lo, hi = float(grid[i_lo]), float(grid[i_hi])
        # a bracket of two grid steps (64 a lobe) holds one local maximum at most: one already found in it is this
        # row's too (the top rows are often neighbours on one peak)
        if any(lo < u < hi for u in refined_t):
            continue
        # start at the vertex of the parabola through the three samples (the bracket's middle at an end)
        v0, v1, v2 = float(vals[i_lo]), float(vals[i]), float(vals[i_hi])
        curv = v0 - 2 * v1 + v2
        vertex = cand_t[row] + 0.5 * (hi - lo) / 2 * (v0 - v2) / curv if curv < 0 else math.nan
        inside = i_lo < i < i_hi and curv < 0 and lo < vertex < hi
        polish = _polish_max if needs_python(d, lo) else polish_max   # compiled unless numpy's sums are needed
        t = polish(d, hk, damping, lo, hi, vertex if inside else 0.5 * (lo + hi))
        if math.isnan(t):
            continue
        half = math.sin(t / 2)
        s_t = math.sin((d + 0.5) * t) / half if half != 0.0 else 2 * d + 1.0
        refined_t.append(t)
        refined_v.append(hk * s_t - damping * math.cos((d + 1) * t))
    # the grid samples stay candidates (θ = 0 and π are ends no interior refinement reaches)
    cand_t += [*refined_t, math.pi]
    cand_v += [*refined_v, v_pi]
    j = max(range(len(cand_v)), key=cand_v.__getitem__)   # the first of equal maxima, as np.argmax
    return cand_v[j], cand_t[j]


def passivity_margin(device: Device, stiffness: float, damping: float) -> PassivityCheck:
    """sup over θ ∈ (0, π] of P(θ), compared with the physical damping b.

    The grid's three largest samples, each refined by Newton on P'(θ) = 0 inside its two grid steps (the
    global maximum may sit between samples).  It replaced three bounded Brent searches (``minimize_scalar``,
    ≈ 0.3-1 ms) with the same answer: tests/optim/stability/test_passivity_fast.py holds the two to 1e-12.
    Only the samples the envelope of optim.stability.passivity_kernel.prefix_samples cannot rule out are computed
    (compiled, as is the polish: the same bits as the Python they replaced), and B = 0 (sup at
    θ = 0) and d = 0 (eq. 3) are answered in closed form, each as the grid would: 2-50 µs instead of
    60-440 µs on the issue-20 loops."""
    d, conservative = passivity_samples(device)
    hk = stiffness * device.sample_time / 2
    if d == 0 and damping > 0.0:
        # eq. 3: s_0 = 1 exactly (the grid's samples too), so P = hk + B·(−cos θ) peaks at θ = π, the grid's
        # last sample, which no refinement exceeds: the general path's answer, bit for bit
        return PassivityCheck(device.damping > hk + damping, hk + damping, d, conservative, math.pi)
    if damping == 0.0 and d > 0:
        # |s_d| < 2d + 1 = s_d(0) away from θ = 0: the sup is the grid's first sample, which no refinement exceeds
        # (the general path's answer, bit for bit)
        v = hk * (2 * d + 1.0) - 0.0
        return PassivityCheck(device.damping > v, v, d, conservative, 0.0)
    if d == 0 and damping == 0.0:
        # P = hk on every sample: the general path's answer is hk at the angle its partition happens to list first
        return PassivityCheck(device.damping > hk, hk, d, conservative, _FLAT_WORST_ANGLE)
    n = 64 * (d + 1) + 257
    hk, damping = float(hk), float(damping)   # one compiled signature, whatever number types came in
    grid, vals, v_pi = prefix_samples(d, n, hk, damping)   # compiled: passivity_kernel
    top = (-vals).argpartition(2)[:3] if vals.size > 3 else np.arange(vals.size)   # np.argpartition, unwrapped
    v_best, t_best, decided = best_of_rows(d, hk, damping, grid, vals, top, v_pi)   # compiled
    if not decided:   # a bracket needs _p_slopes_at's numpy sums: the rows in Python
        v_best, t_best = _best_of_rows(d, hk, damping, grid, vals, top.tolist(), v_pi)
    # the polished maxima are where P is largest only if no lobe between samples is higher: the proven bound
    upper, _, t_best, err = sup_bound(d, n, hk, damping, grid, vals, v_best, t_best, SUP_TOL)   # compiled
    return PassivityCheck(device.damping > upper, upper, d, conservative, t_best, err)


def is_passive(device: Device, stiffness: float, damping: float) -> bool:
    """b > P(θ) for every θ (strict, as in eq. 3)."""
    return passivity_margin(device, stiffness, damping).passive


def largest_passive_stiffness(device: Device, damping: float) -> PassiveStiffness:
    """sup of the passive K [N/m] at virtual damping B = ``damping`` [N·s/m]."""
    if not (math.isfinite(damping) and damping >= 0.0):
        raise InputError("damping", "virtual damping B must be finite and ≥ 0")
    d, conservative = passivity_samples(device)
    b, half_t = device.damping, device.sample_time / 2
    theta = _grid(d)
    s, _ = kernel(theta, d)

    def ratio(t: np.ndarray) -> np.ndarray:
        ss, cc = kernel(t, d)
        sl = b + damping * cc
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(ss > 0, sl / (half_t * np.where(ss > 0, ss, 1.0)), np.inf)

    def neg_ratio_lower(t: np.ndarray) -> np.ndarray:
        ss, cc = kernel(t, d)
        sl = b + damping * cc
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(ss < 0, -sl / (half_t * np.where(ss < 0, ss, -1.0)), np.inf)

    # where s_d = 0 (and at every θ where it changes sign) P = −B·c must stay below b
    zeros = np.array([2 * math.pi * k / (2 * d + 1) for k in range(1, d + 1)])
    if zeros.size and np.any(b + damping * np.cos((d + 1) * zeros) <= 0):
        return PassiveStiffness(0.0, damping, None, d, conservative,
                                reason=f"with {d} samples of delay and B = {damping:.6g} N·s/m, b = {b:.6g} N·s/m "
                                       "cannot exceed −B·cos((d+1)θ) where the kernel vanishes: no K is passive")
    r = ratio(theta)
    upper_t, upper = _refine_min(ratio, theta, r, int(np.argmin(r)))
    # where s_d < 0 passivity bounds K from below; the set is empty when that bound reaches the upper one
    lower = 0.0
    if np.any(s < 0):
        lr = neg_ratio_lower(theta)
        lower = max(0.0, -_refine_min(neg_ratio_lower, theta, lr, int(np.argmin(lr)))[1])
    if upper > 0.0 and math.isfinite(upper) and upper > lower:
        upper, upper_t = _no_lobe_above(device, damping, theta, ratio, upper, upper_t)
    if not (upper > 0.0) or upper <= lower:
        return PassiveStiffness(0.0, damping, None, d, conservative,
                                reason=f"no positive stiffness is passive with b = {b:.6g} N·s/m, B = {damping:.6g} "
                                       f"N·s/m and {d} samples of delay"
                                       + (" (fractional delay rounded up)" if conservative else ""))
    return PassiveStiffness(float(upper), damping, upper_t, d, conservative)


def _no_lobe_above(device: Device, damping: float, theta: np.ndarray, ratio, upper: float,
                   upper_t: float) -> tuple[float, float]:
    """The grid's smallest ratio, refined, binds only if no lobe between samples binds harder: check it with the
    proven sup (``passivity_margin`` at K = upper: the largest value of P met must not exceed b beyond its error
    bound).  Where a lobe does, its angle (the sup's) is refined as the grid's was and K lowered to it; after a few
    such rounds, bisection on K with the proven check (P is linear in K for each θ, so sup P is convex in K and
    the passive K form an interval)."""
    b = device.damping
    for _ in range(6):
        chk = passivity_margin(device, upper, damping)
        if chk.required_damping - chk.error_bound <= b or chk.worst_angle is None:
            return _proven_passive(device, damping, upper), upper_t
        i = int(np.clip(np.searchsorted(theta, chk.worst_angle), 0, theta.size - 1))
        t_new, k_new = _refine_min(ratio, theta, ratio(theta), i)
        r_w = float(ratio(np.array([chk.worst_angle]))[0])
        if r_w < k_new:
            t_new, k_new = chk.worst_angle, r_w
        if not k_new < upper:
            break
        upper, upper_t = k_new, t_new
    return _bisect_passive(device, damping, 0.0, upper, 64), upper_t   # proven passive (the lower end)


def _bisect_passive(device: Device, damping: float, good: float, bad: float, steps: int) -> float:
    """``steps`` halvings of [good, bad] [N/m] on passivity_margin's proof (good proven passive or 0, bad not: the
    passive K are an interval); the last proven-passive end."""
    for _ in range(steps):
        mid = 0.5 * (good + bad)
        if passivity_margin(device, mid, damping).passive:
            good = mid
        else:
            bad = mid
    return good


def _proven_passive(device: Device, damping: float, upper: float) -> float:
    """The largest K ≤ ``upper`` that passivity_margin proves passive (its bound below b), to 1e-6 of the last
    back-off: ``upper`` itself when proven; else back-offs 1e-12, 1e-11, …, 0.1 of it, then bisection between the
    last two (from 0 when none is proven).  The passive K are an interval (sup P is convex in K), so every K below the answer is passive too; where b
    equals the sup at ``upper`` to within the bound's error, the answer lies below the true supremum by about that
    error over ∂P/∂K (issue 34: a design backed off by 1e-8 is not always outside that band)."""
    if passivity_margin(device, upper, damping).passive:
        return upper
    bad = upper
    for j in range(6, 18):
        k = upper * (1.0 - 10.0 ** (j - 18))    # back-offs 1e-12, 1e-11, …, 0.1 of upper
        if not k > 0.0:
            break
        if passivity_margin(device, k, damping).passive:
            return _bisect_passive(device, damping, k, bad, 20)
        bad = k
    return _bisect_passive(device, damping, 0.0, bad, 64)


def max_passive_stiffness(device: Device, damping: float) -> float:
    """sup of the passive K [N/m] at B = ``damping``; 0 when no K > 0 is passive."""
    return largest_passive_stiffness(device, damping).stiffness


def passive_alpha_on_grid(delta: float, d: int, betas: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Dimensionless sup of passive α for many β at once, on the θ grid (a seed, not refined).

    Returns (α_max per β, 0 where nothing is passive; θ where the bound binds).
    """
    theta = _grid(d)
    s, c = kernel(theta, d)
    slack = delta + np.asarray(betas, float)[:, None] * c[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = 2 * slack / s[None, :]
    upper = np.where(s[None, :] > 0, ratio, np.inf)
    lower = np.where(s[None, :] < 0, ratio, -np.inf).max(axis=1)
    j = np.argmin(upper, axis=1)
    up = upper[np.arange(upper.shape[0]), j]
    ok = (up > np.maximum(lower, 0.0)) & np.all(np.where(np.abs(s)[None, :] < 1e-12, slack > 0, True), axis=1)
    return np.where(ok, up, 0.0), theta[j]


def batch_required_damping(d: int, half_tk: np.ndarray, damping: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """sup over θ ∈ [0, π] of P(θ) = (K·T/2)·s_d(θ) − B·cos((d+1)θ) for many (K·T/2, B) with the same d.

    The vectorised form of ``passivity_margin`` (the study path): the same grid, its three largest
    samples per row refined by golden-section search over [θ_{i−1}, θ_{i+1}] in lock step (P is smooth
    there; the bounded Brent search of ``passivity_margin`` is the second computation in the tests).
    Each row's maximum then seeds the proven bound (``sup_bound``), as in ``passivity_margin``: the required damping
    is never below the sup, and at most 1e-13 of P's scale plus its rounding bound above it.
    Returns (required damping [N·s/m], worst θ [rad]) per row.
    """
    half_tk = np.asarray(half_tk, float)
    damping = np.asarray(damping, float)
    theta = _grid(d)
    s, c = kernel(theta, d)
    p = half_tk[:, None] * s[None, :] - damping[:, None] * c[None, :]
    n, m = p.shape
    top = np.argpartition(-p, min(3, m) - 1, axis=1)[:, :3]
    rows = np.repeat(np.arange(n), top.shape[1])
    idx = top.ravel()
    a, b = theta[np.maximum(idx - 1, 0)], theta[np.minimum(idx + 1, m - 1)]
    kk, bb = half_tk[rows], damping[rows]

    def f(t: np.ndarray) -> np.ndarray:
        ss, cc = kernel(t, d)
        return kk * ss - bb * cc

    t_best, neg = golden_minimum(lambda t: -f(t), a, b, _GOLDEN_STEPS)
    t_ref = t_best.reshape(n, -1)
    v_ref = (-neg).reshape(n, -1)
    # the grid samples themselves stay candidates (θ = 0 and π are ends no bracket interior reaches)
    v_grid = p[np.arange(n)[:, None], top]
    better = v_ref > v_grid
    t_all = np.where(better, t_ref, theta[top])
    v_all = np.where(better, v_ref, v_grid)
    j = np.argmax(v_all, axis=1)
    v_top, t_top = v_all[np.arange(n), j], t_all[np.arange(n), j]
    # as passivity_margin: the refined maxima are the sup only if no lobe between samples is higher; each row's
    # required damping is the proven bound (optim.stability.passivity_kernel.sup_bound) from there
    out_v, out_t = np.empty(n), np.empty(n)
    for r in range(n):
        hk_r, b_r = float(half_tk[r]), float(damping[r])
        if d == 0 or b_r == 0.0:   # passivity_margin's closed forms (eq. 3; B = 0: the sup at θ → 0)
            out_v[r], out_t[r] = (hk_r + b_r, math.pi) if d == 0 and b_r > 0.0 else (hk_r * (2 * d + 1.0), 0.0)
            continue
        out_v[r], _, out_t[r], _ = sup_bound(d, m, float(half_tk[r]), float(damping[r]), theta, p[r],
                                             float(v_top[r]), float(t_top[r]), SUP_TOL)
    return out_v, out_t
