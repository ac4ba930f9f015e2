"""The stability boundary as a curve, cut into pieces where the set of crossovers is fixed.

Im H(θ, β) = 0 gives β directly: β_c(θ) = −Im(1/G_n(e^{jθ}))/sin θ, and the
stiffness that puts a pole at e^{jθ} is α_c(θ) = −Re(1/G_n) − β_c(θ)(1 − cos θ).
So the boundary of Fig. 9 is the curve θ ↦ (β_c, α_c) and K_cr(β) is the
smallest positive α_c over the θ with β_c(θ) = β, plus the Nyquist crossover
H(π, β) = −1/G_n(−1) − 2β, which is real for every β.

Between two folds of β_c (its local extrema) each monotone piece of the curve
gives one crossover θ(β), a smooth function: on a β interval free of fold
values the crossovers can be tracked as smooth decision variables, which is
what the CasADi problem does.  This module finds those intervals and a coarse
profile of the design objective on them (a seed, never the answer: the
answer comes from the NLP and is re-checked by the exact analysis).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize_scalar

from models.device import Device
from models.plants import stiffness_loop_plant
from optim.stability.crossovers import scan_grid
from optim.stability.crossovers import theta_min as scan_theta_min

__all__ = ["Piece", "BoundaryCurve", "boundary_curve", "coarse_critical", "crossings_at"]

_REFINE_ROUNDS = 8
_REL_STEP = 0.01          # largest step along the curve, relative to the design's scales


@dataclass(frozen=True)
class Piece:
    """A monotone run of β_c(θ): one crossover θ(β) for β in [beta_lo, beta_hi]."""

    theta_lo: float
    theta_hi: float
    beta_lo: float
    beta_hi: float


@dataclass(frozen=True)
class BoundaryCurve:
    theta: np.ndarray
    beta: np.ndarray
    alpha: np.ndarray
    pieces: tuple[Piece, ...]
    nyquist: tuple[float, float]
    """(a, b) with H(π, β) = a − 2β... stored as (−Re 1/G_n(−1), 2)."""
    breakpoints: tuple[float, ...]
    """β values (dimensionless) where crossovers appear or vanish."""
    plant: object = field(default=None, compare=False, repr=False)
    """the sampled plant the curve came from: a segment whose α changes sign is solved on it (``_straddle_alpha``)."""

    def nyquist_alpha(self, beta: np.ndarray) -> np.ndarray:
        return self.nyquist[0] - self.nyquist[1] * beta


def _curve_values(plant, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    inv = plant.inverse_response(theta)
    beta = -inv.imag / np.sin(theta)
    alpha = -inv.real + beta * np.expm1(-1j * theta).real
    return beta, alpha


def boundary_curve(device: Device, beta_hi: float) -> BoundaryCurve:
    """Sample the boundary curve finely where it matters for β ∈ [0, beta_hi] (dimensionless)."""
    plant = stiffness_loop_plant(device)
    ds = device.delay_samples
    theta_min = scan_theta_min(max(device.delta, 1e-12), ds)
    hints = tuple(plant.pole_angles()) + tuple(plant.zero_angles())
    theta = scan_grid(theta_min, ds, hints, width_hint=device.delta)
    theta = theta[theta < math.pi * (1 - 1e-7)]
    beta, alpha = _curve_values(plant, theta)
    b_scale = max(beta_hi, 1e-300)
    for _ in range(_REFINE_ROUNDS):
        relevant = ((beta[:-1] > -0.05 * b_scale) | (beta[1:] > -0.05 * b_scale)) & \
                   ((beta[:-1] < 1.05 * b_scale) | (beta[1:] < 1.05 * b_scale)) & ((alpha[:-1] > 0) | (alpha[1:] > 0))
        a_scale = max(float(np.max(np.where(relevant, np.maximum(alpha[:-1], alpha[1:]), 0.0))), 1e-300)
        big = relevant & ((np.abs(np.diff(beta)) > _REL_STEP * b_scale) | (np.abs(np.diff(alpha)) > _REL_STEP * a_scale))
        big &= np.diff(theta) > 1e-12 * theta[1:]
        if not big.any():
            break
        mids = 0.5 * (theta[:-1][big] + theta[1:][big])
        mb, ma = _curve_values(plant, mids)
        theta = np.concatenate([theta, mids])
        order = np.argsort(theta)
        theta, beta, alpha = theta[order], np.concatenate([beta, mb])[order], np.concatenate([alpha, ma])[order]
    pieces, folds = _pieces(plant, theta, beta, alpha, b_scale)
    ends = [p.beta_lo for p in pieces] + [p.beta_hi for p in pieces]
    brk = sorted({float(v) for v in ends + folds if 1e-9 * beta_hi < v < beta_hi * (1 - 1e-9)})
    return BoundaryCurve(theta, beta, alpha, tuple(pieces), (_nyquist_offset(plant), 2.0), tuple(brk), plant)


def _nyquist_offset(plant) -> float:
    """−1/G_n(−1), real by symmetry, as −1/Re G_n(−1) (−inf: G_n(−1) = 0, no Nyquist crossover).

    Taken from G, not 1/G: when G has its zero at z = −1 (the ZOH of a bare double integrator, b = 0 with a
    whole delay) 1/G(−1) is 0/0 in rounding (−8 − 6.5e16j for m = 5.4, T = 1 ms), its real part meaningless,
    while Re G(−1) is a rounding-sized number whose reciprocal is far above any design (or negative)."""
    g = complex(plant.response(np.array([math.pi]))[0])
    if not (math.isfinite(g.real) and g.real != 0.0):
        return -math.inf if g.real == 0.0 else 0.0
    return -1.0 / g.real


def _pieces(plant, theta, beta, alpha, b_scale) -> tuple[list[Piece], list[float]]:
    db = np.sign(np.diff(beta))
    turns = np.nonzero(db[1:] * db[:-1] < 0)[0] + 1
    bounds = [0] + [int(i) for i in turns] + [theta.size - 1]
    # refine each fold to full precision: its β is where a pair of crossovers is born or dies
    fold_theta: dict[int, tuple[float, float]] = {}
    for i in turns:
        if not (-0.05 * b_scale < beta[i] < 1.05 * b_scale and alpha[i] > 0):
            fold_theta[int(i)] = (float(theta[i]), float(beta[i]))
            continue
        sign = 1.0 if db[i - 1] > 0 else -1.0             # local max of β_c when rising before it
        res = minimize_scalar(lambda t: -sign * float(_curve_values(plant, np.array([t]))[0][0]),
                              bounds=(theta[i - 1], theta[i + 1]), method="bounded", options={"xatol": 1e-15})
        tb = float(res.x)
        bb = -sign * float(res.fun)
        if sign * bb < sign * beta[i]:
            tb, bb = float(theta[i]), float(beta[i])
        fold_theta[int(i)] = (tb, bb)
    pieces = []
    for k0, k1 in zip(bounds[:-1], bounds[1:]):
        t0, b0 = fold_theta.get(k0, (float(theta[k0]), float(beta[k0])))
        t1, b1 = fold_theta.get(k1, (float(theta[k1]), float(beta[k1])))
        pieces.append(Piece(t0, t1, min(b0, b1), max(b0, b1)))
    return pieces, [v[1] for v in fold_theta.values()]


def _segments(curve: BoundaryCurve, betas: np.ndarray):
    """For each β and each relevant curve segment: crossed?, interpolation weight, α there (clamped at 0)."""
    b0, b1 = curve.beta[:-1], curve.beta[1:]
    a0, a1 = curve.alpha[:-1], curve.alpha[1:]
    # only segments that reach the β range asked for and have α > 0 at an end can matter
    keep = np.nonzero((np.maximum(b0, b1) >= betas.min()) & (np.minimum(b0, b1) <= betas.max())
                      & ((a0 > 0) | (a1 > 0)))[0]
    b0, b1, a0, a1 = b0[keep], b1[keep], a0[keep], a1[keep]
    x = betas[:, None]
    # half-open segments: a crossing through a vertex is counted once
    cross = (np.minimum(b0, b1) <= x) & (x < np.maximum(b0, b1))
    with np.errstate(divide="ignore", invalid="ignore"):
        w = np.where(cross, (x - b0) / (b1 - b0), 0.0)
    alpha = a0 + w * (a1 - a0)
    straddle = cross & (a0 * a1 < 0)
    if straddle.any():
        rows, cols = np.nonzero(straddle)
        alpha[rows, cols] = _straddle_alpha(curve, keep[cols], betas[rows])
    return cross & (alpha > 0), w, np.maximum(alpha, 0.0), keep


def _straddle_alpha(curve: BoundaryCurve, segments: np.ndarray, betas: np.ndarray) -> np.ndarray:
    """α_c where the curve crosses β inside segments whose ends have α of opposite signs, solved on the plant.

    Linear interpolation is no estimate there: a segment the sampling left long (near θ = π with a long delay,
    β_c swings by ~d/(π − θ)² between neighbours) joins a large negative α to a positive one, and its
    interpolated α ≤ 0 would read as "K_cr = 0 at every β it spans" — a false "infeasible" (issue 17: 18 of
    301 delays between 200 and 1,700 samples).  Bisection of β_c(θ) = β in the segment (to 1 ulp of θ) gives
    the crossing's own α; near B_max, where the curve truly reaches α = 0, it gives the small true α.
    A crossing with α ≤ 0 is a crossover of negative stiffness: not a bound on K > 0 (the callers drop it).
    """
    if curve.plant is None:
        return np.full(betas.shape, 1e-300)   # no plant to solve on: the conservative reading, K_cr → 0⁺
    lo, hi = curve.theta[segments].copy(), curve.theta[segments + 1].copy()
    s_lo = np.sign(curve.beta[segments] - betas)
    for _ in range(64):
        mid = 0.5 * (lo + hi)
        bm, _ = _curve_values(curve.plant, mid)
        same = np.sign(bm - betas) == s_lo
        lo, hi = np.where(same, mid, lo), np.where(same, hi, mid)
        if np.all(hi - lo <= 4e-16 * hi):
            break
    # the end of the final bracket nearer the asked β in value
    bl, al = _curve_values(curve.plant, lo)
    bh, ah = _curve_values(curve.plant, hi)
    return np.where(np.abs(bl - betas) <= np.abs(bh - betas), al, ah)


def coarse_critical(curve: BoundaryCurve, betas: np.ndarray) -> np.ndarray:
    """K_cr(β)/(m/T²) linearly interpolated on the sampled curve, for each β (inf: no crossover).

    Sparse form of ``_segments``: each segment crosses only the β's in its half-open range
    [min(b0, b1), max(b0, b1)), found by bisection in the sorted β's, so the work is the number of
    (β, crossing) pairs, not β's × segments."""
    betas = np.asarray(betas, dtype=float)
    order = np.argsort(betas, kind="stable")
    sb = betas[order]
    b0, b1 = curve.beta[:-1], curve.beta[1:]
    a0, a1 = curve.alpha[:-1], curve.alpha[1:]
    keep = (a0 > 0) | (a1 > 0)
    b0, b1, a0, a1 = b0[keep], b1[keep], a0[keep], a1[keep]
    lo, hi = np.minimum(b0, b1), np.maximum(b0, b1)
    start = np.searchsorted(sb, lo, side="left")
    stop = np.searchsorted(sb, hi, side="left")
    counts = np.maximum(stop - start, 0)
    kcr = np.full(sb.shape, np.inf)
    total = int(counts.sum())
    if total:
        seg = np.repeat(np.arange(counts.size), counts)
        first = np.repeat(np.cumsum(counts) - counts, counts)
        idx = np.repeat(start, counts) + (np.arange(total) - first)
        x = sb[idx]
        w = (x - b0[seg]) / (b1[seg] - b0[seg])
        alpha = a0[seg] + w * (a1[seg] - a0[seg])
        straddle = a0[seg] * a1[seg] < 0
        if straddle.any():
            alpha[straddle] = _straddle_alpha(curve, np.nonzero(keep)[0][seg[straddle]], x[straddle])
        np.minimum.at(kcr, idx, np.where(alpha > 0, alpha, np.inf))
    out = np.empty_like(kcr)
    out[order] = kcr
    nyq = curve.nyquist_alpha(betas)
    return np.where(nyq > 0, np.minimum(out, nyq), out)


def _coarse_critical_dense(curve: BoundaryCurve, betas: np.ndarray) -> np.ndarray:
    """The dense (β's × segments) form of coarse_critical, kept as the test's second computation."""
    pos, _, alpha, _ = _segments(curve, betas)
    kcr = np.where(pos, alpha, np.inf).min(axis=1) if pos.shape[1] else np.full(betas.shape, np.inf)
    nyq = curve.nyquist_alpha(betas)
    return np.where(nyq > 0, np.minimum(kcr, nyq), kcr)


def crossings_at(curve: BoundaryCurve, beta: float, with_alpha: bool = False) -> list[tuple[float, float]]:
    """The interior crossovers with α > 0 at β, as (θ interpolated on the curve, its piece index or its α)."""
    pos, w, alpha, keep = _segments(curve, np.array([beta]))
    sel = np.nonzero(pos[0])[0]
    idx = keep[sel]
    t0, t1 = curve.theta[idx], curve.theta[idx + 1]
    starts = np.searchsorted(curve.theta, [p.theta_lo for p in curve.pieces], side="left")
    piece = np.searchsorted(starts, idx, side="right") - 1
    if with_alpha:
        return [(float(a + w[0, j] * (b - a)), float(alpha[0, j])) for a, b, j in zip(t0, t1, sel)]
    return [(float(a + w[0, j] * (b - a)), int(k)) for a, b, j, k in zip(t0, t1, sel, piece)]
