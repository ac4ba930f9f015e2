"""Independent checks of a robust design: corners + random points, and a dense (B, box-grid) search."""

from __future__ import annotations

import itertools

import numpy as np
from scipy.optimize import minimize_scalar

from models.discretize import split_delay
from optim.robust.batch import batch_critical_stiffness
from optim.robust.box import UncertaintyBox
from optim.stability.margins import max_stable_damping


def min_margin_db(box: UncertaintyBox, k: float, b: float, n_random: int = 2000, seed: int = 99) -> float:
    """Smallest 20·log10(K_cr/K) over every corner and n_random uniform points of the box."""
    rng = np.random.default_rng(seed)
    pts = np.concatenate([box.corners(), box.lower + rng.random((n_random, box.dim)) * (box.upper - box.lower)])
    kcr = batch_critical_stiffness(box.devices(pts), b).critical_stiffness
    assert kcr.size == len(box.corners()) + n_random
    with np.errstate(divide="ignore"):
        return float(np.min(20 * np.log10(kcr / k)))


def dense_best(box: UncertaintyBox, gain: float, per_axis: int = 9, b_points: int = 41,
               b_cap: float = np.inf) -> tuple[float, float]:
    """(best K, its B) of max_B g·min_{grid} K_cr(B; p): a B scan and a bounded refinement of the best B.

    The grid minimum is ≥ the true minimum over the box, so this K is an upper bound (up to the grid's
    fineness) of what any design can safely reach: a design well below it is over-conservative.
    """
    axes = [np.linspace(lo, hi, per_axis) if hi > lo else np.array([lo]) for lo, hi in zip(box.lower, box.upper)]
    pts = np.array(list(itertools.product(*axes)))
    devices = box.devices(pts)
    upper = min(min(max_stable_damping(d) for d in box.devices(box.corners())), b_cap)

    def worst(b: float) -> float:
        return gain * float(np.min(batch_critical_stiffness(devices, b).critical_stiffness))

    grid = np.linspace(0.0, upper, b_points)
    grid[-1] = upper * (1 - 1e-9) if np.isinf(b_cap) or b_cap > upper else upper
    vals = np.array([worst(b) for b in grid])
    i = int(np.argmax(vals))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    res = minimize_scalar(lambda b: -worst(b), bounds=(lo, hi), method="bounded", options={"xatol": 1e-9 * upper})
    return (float(-res.fun), float(res.x)) if -res.fun > vals[i] else (float(vals[i]), float(grid[i]))


# ---- passivity, computed independently of optim.stability.passivity and optim.robust.passivity -------------------------
# P(θ) = (K·T/2)·s_n(θ) − B·cos((n+1)θ) with s_n = 1 + 2·Σ_{k≤n} cos kθ summed term by term (optim.stability.passivity
# uses the closed form sin((n+½)θ)/sin(θ/2)); n = ⌈t_d/T⌉ by the device model's own rule
# (models.discretize.split_delay).

_THETA = np.linspace(0.0, np.pi, 20001)        # θ = 0 is the limit θ → 0⁺


def whole_delay(delay: np.ndarray, sample_time: np.ndarray) -> np.ndarray:
    """n = ⌈t_d/T⌉ per device (a ratio within 64 ulp of a whole number is that number, as the model does)."""
    out = []
    for r in np.asarray(delay, float) / np.asarray(sample_time, float):
        whole, frac = split_delay(float(r))
        out.append(whole + (frac > 0))
    return np.array(out, int)


def _dirichlet(theta: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """s_n(θ) by its sum, s_n'(θ) and cos((n+1)θ)."""
    k = np.arange(1, n + 1)[:, None]
    s = 1.0 + 2.0 * np.cos(k * theta[None, :]).sum(axis=0)
    ds = -2.0 * (k * np.sin(k * theta[None, :])).sum(axis=0)
    return s, ds, np.cos((n + 1) * theta)


def sup_p(sample_time: np.ndarray, n: np.ndarray, k: float, b: float) -> np.ndarray:
    """sup over θ ∈ (0, π] of P for each device: a 20 001-point grid, then Newton on P' from the grid's best."""
    sample_time, n = np.asarray(sample_time, float), np.asarray(n, int)
    out = np.empty(sample_time.shape)
    for m in np.unique(n):
        s, _, c = _dirichlet(_THETA, int(m))
        for idx in np.array_split(np.nonzero(n == m)[0], max(1, int(np.sum(n == m)) // 200)):
            out[idx] = _sup_rows(sample_time[idx], int(m), s, c, k, b)
    return out


def _sup_rows(t: np.ndarray, n: int, s: np.ndarray, c: np.ndarray, k: float, b: float) -> np.ndarray:
    vals = 0.5 * k * t[:, None] * s[None, :] - b * c[None, :]
    j = np.argmax(vals, axis=1)
    best = vals[np.arange(t.size), j]
    lo, hi = _THETA[np.maximum(j - 1, 0)], _THETA[np.minimum(j + 1, _THETA.size - 1)]
    th = _THETA[j].copy()
    for _ in range(8):          # Newton on P'(θ) = 0, kept inside the grid cells around the best sample
        p, d1, d2 = _p(th, t, n, k, b)
        th = np.clip(np.where(d2 < 0, th - d1 / np.where(d2 < 0, d2, -1.0), th), lo, hi)
    return np.maximum(best, _p(th, t, n, k, b)[0])


def _p(theta: np.ndarray, t: np.ndarray, n: int, k: float, b: float):
    """P(θ), P'(θ), P''(θ) row by row (one θ per device)."""
    kk = np.arange(1, n + 1)[None, :]
    arg = kk * theta[:, None]
    s = 1.0 + 2.0 * np.cos(arg).sum(axis=1)
    ds = -2.0 * (kk * np.sin(arg)).sum(axis=1)
    dds = -2.0 * (kk**2 * np.cos(arg)).sum(axis=1)
    q = (n + 1) * theta
    return (0.5 * k * t * s - b * np.cos(q), 0.5 * k * t * ds + b * (n + 1) * np.sin(q),
            0.5 * k * t * dds + b * (n + 1) ** 2 * np.cos(q))


def box_sample(box: UncertaintyBox, n_random: int, seed: int) -> np.ndarray:
    """Every corner and n_random uniform points of the box."""
    rng = np.random.default_rng(seed)
    return np.concatenate([box.corners(), box.lower + rng.random((n_random, box.dim)) * (box.upper - box.lower)])


def passive_stiffness_bounds(b: float, n: int, damping: float) -> tuple[float, float]:
    """(R, L) with the passive K of a device (b, T, n) at B = ``damping`` being (2L/T, 2R/T) (P is linear in K
    and K enters as K·T): R = min over s_n > 0 of (b + B·c)/s_n, L = max over s_n < 0 (−inf if s_n ≥ 0); a
    20 001-point θ grid (the grid's R is ≥ the true one: an upper bound on the passive K)."""
    s, _, c = _dirichlet(_THETA, n)
    slack = b + damping * c
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.min(np.where(s > 1e-9, slack / s, np.inf))
        lo = np.max(np.where(s < -1e-9, slack / s, -np.inf))
    if np.any((np.abs(s) <= 1e-9) & (slack <= 0)) or not r > 0:
        return 0.0, np.inf                     # no K > 0 is passive
    return float(r), float(lo)


def dense_best_passive(box: UncertaintyBox, gain: float, axes: dict[str, int], t_points: int = 2001,
                       b_points: int = 25, b_cap: float = np.inf) -> tuple[float, float]:
    """(best K, its B) of max_B min(g·min_{grid} K_cr(B; p), min_{fine grid} passive K(B; p), caps).

    Gain part: a grid with ``axes[path]`` points on each uncertain path (batch exact analysis).  Passivity part:
    a fine grid over the paths passivity depends on (t_points on the sample time, axes[...] on the others), with
    each device's b, T and ⌈t_d/T⌉.  Both grids are sets of real devices of the box, so the answer is an upper
    bound (to the grids' fineness) of any design that is passive and keeps the margin on every device.  B: 0 and
    a log scan up to B_max (a passive wall's B is often ≪ B_max), refined by a bounded search.
    """
    grid_axes = [np.linspace(lo, hi, axes.get(p, 2)) if hi > lo else np.array([lo])
                 for p, lo, hi in zip(box.paths, box.lower, box.upper)]
    devices = box.devices(np.array(list(itertools.product(*grid_axes))))
    # the passivity grid: b from the damping paths (other paths do not enter), T fine, t_d as given
    pas_axes = []
    for p, lo, hi, ax in zip(box.paths, box.lower, box.upper, grid_axes):
        if p == "device.sample_time" and hi > lo:
            pas_axes.append(np.linspace(lo, hi, t_points))
        elif p in ("device.damping", "device.cable.motor_damping", "device.cable.body_damping", "device.delay"):
            pas_axes.append(ax)
        else:
            pas_axes.append(np.array([box.nominal_point()[box.paths.index(p)]]))
    pts = np.array(list(itertools.product(*pas_axes)))
    nom = box.nominal

    def column(path, default):
        return pts[:, box.paths.index(path)] if path in box.paths else np.full(len(pts), default)

    t_col, d_col = column("device.sample_time", nom.sample_time), column("device.delay", nom.delay)
    damp_cols = [p for p in ("device.damping", "device.cable.motor_damping", "device.cable.body_damping")
                 if p in box.paths]
    keys = [tuple(pts[i, [box.paths.index(p) for p in damp_cols]]) for i in range(len(pts))]
    b_of: dict[tuple, float] = {}
    for i, key in enumerate(keys):
        if key not in b_of:
            b_of[key] = box.device_at(pts[i]).damping
    b_col = np.array([b_of[key] for key in keys])
    n_col = whole_delay(d_col, t_col)
    groups = {}
    for i, key in enumerate(zip(b_col, n_col)):
        groups.setdefault(key, []).append(i)
    upper = min(min(max_stable_damping(d) for d in box.devices(box.corners())), b_cap)

    def passive(bb: float) -> float:
        k_hi, k_lo = np.inf, 0.0
        for (b, n), idx in groups.items():
            r, lo = passive_stiffness_bounds(b, int(n), bb)
            t = t_col[idx]
            k_hi = min(k_hi, float(np.min(2 * r / t)))
            if np.isfinite(lo):
                k_lo = max(k_lo, float(np.max(2 * lo / t)))
        return k_hi if k_hi > k_lo else 0.0

    def worst(bb: float, devs=devices) -> float:
        return min(gain * float(np.min(batch_critical_stiffness(devs, bb).critical_stiffness)), passive(bb))

    grid = np.concatenate([[0.0], upper * np.geomspace(1e-6, 1.0, b_points)])
    grid[-1] = upper * (1 - 1e-9) if np.isinf(b_cap) or b_cap > upper else upper
    vals = np.array([worst(b) for b in grid])
    i = int(np.argmax(vals))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    # the bounded refinement of B runs on the grid devices within 2 % of the smallest K_cr anywhere in the bracket
    # (a cost cut only: the value returned is the whole grid's, evaluated again at the B found)
    kcr = np.array([batch_critical_stiffness(devices, bb).critical_stiffness for bb in (lo, 0.5 * (lo + hi), hi)])
    near = [devices[j] for j in np.nonzero(np.any(kcr <= 1.02 * kcr.min(axis=1, keepdims=True), axis=0))[0]]
    res = minimize_scalar(lambda b: -worst(b, near), bounds=(lo, hi), method="bounded",
                          options={"xatol": 1e-10 * upper})
    k_res = worst(float(res.x))
    return (k_res, float(res.x)) if k_res > vals[i] else (float(vals[i]), float(grid[i]))
