"""Every point on (0, π] where a sampled loop's frequency function is real and positive.

For the wall C(z) = K + B(1 - z⁻¹)/T the closed loop has a pole at z = e^{jθ}
exactly when K = H(θ) = -1/G(e^{jθ}) - B(1 - e^{-jθ})/T.  A phase crossover of
the loop is a θ where H(θ) is real; it matters for K > 0 when H(θ) > 0.

The scan is adaptive: a log grid from far below the lowest possible crossover
(≈ sqrt((δ+β)/(d+½)), FIELD-NOTES.md), a linear grid fine enough for the delay's
phase (z^d turns by dθ), dense clusters around the plant's resonances and
anti-resonances, then bisection of every interval where arg H turns by more than
a quarter radian, so consecutive samples can't hide a crossing.  Each sign
change of Im H with Re H > 0 is refined to full double precision, all at once.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

__all__ = ["Crossing", "positive_real_crossings", "scan_grid", "theta_min", "LOG_PER_DECADE", "LOG_END", "LOG_MIN_SAMPLES",
           "LIN_STEP", "STEPS_PER_DELAY_TURN", "CLUSTER_HALF_WIDTH", "CLUSTER_POINTS", "CLUSTER_GEOM", "refine_grid", "solve_brackets", "tangential_pairs"]

# The scan grid's constants, shared with the batched scan of optim.robust.batch (one place to change them):
LOG_PER_DECADE = 60           # log samples per decade from θ_min ...
LOG_END = 0.05                # ... up to this angle [rad/sample] (or 10 θ_min)
LOG_MIN_SAMPLES = 40
LIN_STEP = 0.02               # then a linear grid, its step at most this ...
STEPS_PER_DELAY_TURN = 16     # ... and π/(16(d+1)), so z^-d turns by < π/16 per step
CLUSTER_HALF_WIDTH = 50       # a cluster of CLUSTER_POINTS around each resonance, ± 50·max(δ, 1e-6) wide,
CLUSTER_POINTS = 201
CLUSTER_GEOM = (1e-9, 0.2, 60)  # and geometric steps h·(1 ± g) on both sides of it

_GEOM_STEPS = np.geomspace(*CLUSTER_GEOM)   # the same steps for every hint: built once (geomspace is slow)
_MAX_ARG_STEP = 0.25          # rad of arg H between consecutive samples after refinement
_MAX_REFINE_ROUNDS = 60


@dataclass(frozen=True)
class Crossing:
    """θ (rad per sample) where H(θ) is real and positive, with the value there."""

    angle: float
    value: float


def theta_min(damp, delay_samples):
    """The scan's lowest angle [rad/sample]: far below the lowest crossover ≈ sqrt(damp/(d + ½)) of the K loop
    (damp = δ + β, dimensionless).  The damper-only loop (β = 0) has its crossovers at O(1/(1 + d)); with no
    damping at all that is the only scale.  Floats or arrays (elementwise: the batched scan's rows get the same
    bits as the scalar scan); the one definition for every scan of the stiffness loop (issue 19)."""
    if type(damp) is float and type(delay_samples) in (float, int):
        # the same IEEE operations in scalars (sqrt, min and max round alike): ~0.3 µs instead of ~14 µs of numpy
        # per call on the fast paths; tests/optim/stability/test_margins.py holds the two to the bit
        scale = 1.0 / (1.0 + 2.0 * float(delay_samples))
        if damp > 0.0:
            return 1e-4 * min(min(1.0, math.sqrt(damp * scale)), 10 * damp)
        return 1e-4 * scale
    damp = np.asarray(damp, dtype=float)
    scale = 1.0 / (1.0 + 2.0 * np.asarray(delay_samples, dtype=float))
    with np.errstate(invalid="ignore"):
        root = np.sqrt(np.maximum(damp, 0.0) * scale)
    out = np.where(damp > 0.0, 1e-4 * np.minimum(np.minimum(1.0, root), 10 * damp), 1e-4 * scale)
    return float(out) if out.ndim == 0 else out


def scan_grid(theta_min: float, delay_samples: float, hints: Sequence[float], width_hint: float = 0.0) -> np.ndarray:
    """Initial samples on [theta_min, π]."""
    # 60 samples per decade all the way up to 0.05 rad, then a linear grid that the delay's
    # phase (d·θ) cannot turn a full circle within.
    theta_lin = max(LOG_END, theta_min * 10)
    parts = [np.geomspace(theta_min, theta_lin,
                          max(LOG_MIN_SAMPLES, int(LOG_PER_DECADE * math.log10(theta_lin / theta_min)) + 2))]
    step = min(LIN_STEP, math.pi / (STEPS_PER_DELAY_TURN * (delay_samples + 1.0)))
    parts.append(np.linspace(theta_lin, math.pi, int(math.ceil((math.pi - theta_lin) / step)) + 1))
    for h in dict.fromkeys(hints):           # a pole pair gives its angle twice: one cluster (np.unique would merge)
        if 0.0 < h <= math.pi:
            w = max(width_hint, 1e-6) * CLUSTER_HALF_WIDTH
            lo, hi = max(theta_min, h - w), min(math.pi, h + w)
            parts.append(np.linspace(lo, hi, CLUSTER_POINTS))
            parts.append(h * (1.0 + _GEOM_STEPS))
            parts.append(h * (1.0 - _GEOM_STEPS))
    grid = np.unique(np.clip(np.concatenate(parts), theta_min, math.pi))
    return grid


def refine_grid(h: Callable[[np.ndarray], np.ndarray], grid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The grid with every interval where arg H turns by more than _MAX_ARG_STEP bisected (up to
    _MAX_REFINE_ROUNDS times), and H on it.  Each round looks only at the intervals the last one made (the others
    stay as they were), in grid order, so h sees the same arrays as when every round re-sorted the whole grid
    (issue 20: that re-sort was most of a long delay's bounded scan): the same samples and values, to the bit."""
    values = h(grid)
    lo, hi, vlo, vhi = grid[:-1], grid[1:], values[:-1], values[1:]
    new_t, new_v = [grid], [values]
    for _ in range(_MAX_REFINE_ROUNDS):
        with np.errstate(divide="ignore", invalid="ignore"):
            turn = np.abs(np.angle(vhi / vlo))
        # a sample exactly at 0 (an undamped pole of G sampled at its angle: 1/G = 0) has no argument
        bad = (turn > _MAX_ARG_STEP) | (vhi == 0) | (vlo == 0)
        bad &= (hi - lo) > 1e-14 * hi
        if not bad.any():
            break
        lo, hi, vlo, vhi = lo[bad], hi[bad], vlo[bad], vhi[bad]
        order = np.argsort(lo, kind="stable")
        lo, hi, vlo, vhi = lo[order], hi[order], vlo[order], vhi[order]
        mids = 0.5 * (lo + hi)
        mid_vals = h(mids)
        new_t.append(mids)
        new_v.append(mid_vals)
        lo, hi = np.concatenate([lo, mids]), np.concatenate([mids, hi])
        vlo, vhi = np.concatenate([vlo, mid_vals]), np.concatenate([mid_vals, vhi])
    if len(new_t) == 1:
        return grid, values
    grid, values = np.concatenate(new_t), np.concatenate(new_v)
    order = np.argsort(grid, kind="stable")
    return grid[order], values[order]


def solve_brackets(f: Callable[[np.ndarray], np.ndarray], a: np.ndarray, b: np.ndarray,
                    fa: np.ndarray, fb: np.ndarray) -> np.ndarray:
    """Roots of f in every bracket [a, b] at once (Illinois regula falsi, bisection-safeguarded).

    Stops when a bracket is 4 ulp wide or f is exactly 0: full double precision.  A step that lands on or
    within 2 ulp of an end goes 2 ulp inside: the root then sits by that end, and the next step closes the
    bracket to 4 ulp, where regula falsi alone crept up on it by bisections (about half the steps of the cable
    bounded scan's B_max, issue 20; the roots stay 4-ulp brackets' ends, within 2 ulp of the old ones).
    """
    a, b, fa, fb = a.copy(), b.copy(), fa.copy(), fb.copy()
    side = np.zeros(a.shape, dtype=int)
    eps = np.finfo(float).eps
    tol = 4 * eps
    x = 0.5 * (a + b)
    for it in range(200):
        active = np.abs(b - a) > tol * np.maximum(np.abs(a), np.abs(b))
        if not active.any():
            break
        with np.errstate(divide="ignore", invalid="ignore"):
            x = np.where(fb != fa, b - fb * (b - a) / (fb - fa), 0.5 * (a + b))
        lo, hi, mid = np.minimum(a, b), np.maximum(a, b), 0.5 * (a + b)
        # every fourth step bisects, so a bracket always shrinks geometrically
        bad = ~((x >= lo) & (x <= hi)) | (it % 4 == 3)
        m = 2 * eps * hi
        x = np.where(bad, mid, np.where(x - lo < m, np.minimum(lo + m, mid),
                                        np.where(hi - x < m, np.maximum(hi - m, mid), x)))
        x = np.where(active, x, a)
        fx = np.where(active, f(x), fa)
        done = fx == 0.0
        left = np.sign(fx) == np.sign(fa)            # root in [x, b]
        # Illinois: halve the stale end's value when the same side is kept twice
        fb = np.where(active & left & (side == 1), fb / 2, fb)
        fa = np.where(active & ~left & (side == -1), fa / 2, fa)
        a_new = np.where(active & left, x, a)
        fa_new = np.where(active & left, fx, fa)
        b_new = np.where(active & ~left, x, b)
        fb_new = np.where(active & ~left, fx, fb)
        side = np.where(active, np.where(left, 1, -1), side)
        a = np.where(done, x, a_new)
        b = np.where(done, x, b_new)
        fa, fb = np.where(done, 0.0, fa_new), np.where(done, 0.0, fb_new)
    return np.where(np.abs(fa) <= np.abs(fb), a, b)


def tangential_pairs(h: Callable[[np.ndarray], np.ndarray], grid: np.ndarray, values: np.ndarray) -> list[Crossing]:
    """Two crossings between samples that share the sign of Im H (a near-tangency).

    Where arg H comes within 0.05 rad of 0 at a local minimum of |arg H| without
    changing sign, minimise the signed arg between the neighbouring samples; if it
    changes sign there, both crossings are bracketed and refined.
    """
    arg = np.angle(values)
    mag = np.abs(arg)
    cand = np.nonzero((mag[1:-1] <= mag[:-2]) & (mag[1:-1] <= mag[2:]) & (mag[1:-1] < 0.05)
                      & (values.real[1:-1] > 0) & (np.sign(arg[:-2]) == np.sign(arg[2:]))
                      & (np.sign(arg[1:-1]) == np.sign(arg[2:])))[0] + 1
    out: list[Crossing] = []
    for i in cand:
        sign = float(np.sign(arg[i]))
        lo, hi = float(grid[i - 1]), float(grid[i + 1])
        res = minimize_scalar(lambda t: sign * float(np.angle(h(np.array([t]))[0])), bounds=(lo, hi),
                              method="bounded", options={"xatol": 1e-15 * hi})
        if res.fun >= 0:
            continue
        tm = float(res.x)
        a = np.array([lo, tm])
        b = np.array([tm, hi])
        fa, fb = h(a).imag, h(b).imag
        roots = solve_brackets(lambda t: h(t).imag, a, b, fa, fb)
        vals = h(roots).real
        out += [Crossing(angle=float(t), value=float(v)) for t, v in zip(roots, vals) if v > 0]
    return out


def positive_real_crossings(h: Callable[[np.ndarray], np.ndarray], grid: np.ndarray) -> list[Crossing]:
    """All θ in the grid's span where h(θ) is real and positive, refined.

    ``grid`` must end at π; h(π) is real for a real-coefficient loop and counts
    as a crossover (the Nyquist frequency, chapter eq. 32) when positive.
    """
    grid, values = refine_grid(h, grid)
    im, re = values.imag, values.real
    found: list[Crossing] = []
    idx = np.nonzero((np.sign(im[:-1]) * np.sign(im[1:]) < 0) & ((re[:-1] > 0) | (re[1:] > 0)))[0]
    if idx.size:
        roots = solve_brackets(lambda t: h(t).imag, grid[idx], grid[idx + 1], im[idx], im[idx + 1])
        vals = h(roots).real
        found += [Crossing(angle=float(t), value=float(v)) for t, v in zip(roots, vals) if v > 0]
    found += tangential_pairs(h, grid, values)
    for i in np.nonzero(im[1:-1] == 0.0)[0] + 1:          # an exact zero on a sample
        if re[i] > 0:
            found.append(Crossing(angle=float(grid[i]), value=float(re[i])))
    v_pi = complex(h(np.array([math.pi]))[0])
    if v_pi.real > 0:
        # The Nyquist point is a crossover by symmetry; a rounding-level sign
        # change of Im H just below π is the same crossover.
        found = [c for c in found if math.pi - c.angle > 1e-9]
        found.append(Crossing(angle=math.pi, value=v_pi.real))
    found.sort(key=lambda c: c.angle)
    return found
