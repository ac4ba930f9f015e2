"""The worst device of an uncertainty box for a fixed wall (K, B), by a global search with the exact analysis.

For a fixed (K, B) the margin of device p is 20·log10(K_cr(B; p)/K), so the worst
device minimises K_cr(B; p) over the box.  K_cr is not monotone in every
parameter (the cable stiffness switches which crossover dominates) and it jumps
where a pair of crossovers is born at a fold, so corners alone are not enough:

1. corners, the centre, the nominal point and a scrambled Sobol sample
   (scipy.stats.qmc) are evaluated in one batch (optim.robust.batch);
2. from the best few distinct points a batched compass (pattern) search polishes
   the minimum down to a step of 1e-9 of the box width: derivative-free, so the
   kinks and jumps of K_cr cannot stall it, and every poll of every start is one
   batch of exact analyses;
3. run to convergence (issue 34: an interior worst case, a dip of K_cr in the cable
   stiffness between two samples, was missed and the design violated its margin
   inside the box): rounds of fresh scrambled Sobol samples, each point below the
   best found by more than ``CONVERGED_RTOL`` a new start of the pattern search,
   until a whole round finds no point below the best (at most ``MAX_ROUNDS``).

Parameters that do not enter the stiffness loop (the user's grasp, the force
sensor) are held at their nominal value (clipped into the box).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.stats import qmc

from models.device import Device
from optim.robust.batch import batch_critical_stiffness
from optim.robust.box import STIFFNESS_PATHS, UncertaintyBox

__all__ = ["WorstCase", "worst_case_stiffness", "box_critical_stiffness", "minimise_over_box"]

_FIRST_STEP = 0.125
_LAST_STEP = 1e-9
_MAX_POLLS = 200
_SCALE = 8.0            # poll steps s, s/8, s/64, s/512 together
_SCALES = 4
#: a fresh sample's point counts as better than the best found when its value is lower by more than this
#: (relative; 1.15e-8 is 1e-7 dB of margin, ten times finer than the design's TOLERANCE_DB)
CONVERGED_RTOL = 1.15e-8
#: rounds of fresh samples at most (each round that finds a better point refines it)
MAX_ROUNDS = 6


@dataclass(frozen=True)
class WorstCase:
    point: np.ndarray
    """box values (order of box.paths) of the worst device."""
    device: Device
    critical_stiffness: float
    """exact K_cr(B) of the worst device [N/m]."""
    crossover_frequency: float | None
    """ω [rad/s] of the crossover that sets it."""
    margin_db: float
    """20·log10(K_cr/K) [dB] (−inf when K_cr = 0)."""
    evaluations: int
    """exact analyses spent by the search."""


def box_critical_stiffness(box: UncertaintyBox, unit: np.ndarray, damping: float) -> tuple[np.ndarray, np.ndarray]:
    """K_cr(B) [N/m] and crossover angle at unit-cube points (rows)."""
    pts = box.to_box(np.atleast_2d(unit))
    res = batch_critical_stiffness(box.devices(pts), damping)
    return res.critical_stiffness, res.crossover_angle


def _start_points(box: UncertaintyBox, active: np.ndarray, samples: int, seed: int) -> np.ndarray:
    base = box.to_unit(box.nominal_point())
    k = int(active.sum())
    pts = [base[None, :]]
    if k:
        corners = np.array(np.meshgrid(*[[0.0, 1.0]] * k, indexing="ij")).reshape(k, -1).T
        c = np.repeat(base[None, :], corners.shape[0], axis=0)
        c[:, active] = corners
        centre = base.copy()
        centre[active] = 0.5
        sob = qmc.Sobol(d=k, scramble=True, seed=seed).random_base2(max(1, math.ceil(math.log2(max(samples, 2)))))
        s = np.repeat(base[None, :], sob.shape[0], axis=0)
        s[:, active] = sob
        pts += [c, centre[None, :], s]
    return np.concatenate(pts)


def _distinct(unit: np.ndarray, order: np.ndarray, starts: int) -> list[int]:
    """Up to ``starts`` indices in ``order`` at least 0.05 of the box apart (max norm)."""
    chosen: list[int] = []
    for i in order:
        if len(chosen) == starts:
            break
        if all(np.max(np.abs(unit[i] - unit[j])) > 0.05 for j in chosen):
            chosen.append(int(i))
    return chosen


def _pattern(box: UncertaintyBox, active: np.ndarray, evaluate, x: np.ndarray, fx: np.ndarray,
             xa: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """The batched compass search from the rows of x (values fx, aux xa): where each start ends."""
    evals = 0
    # each poll tries every direction at several scales at once: one batch call instead of many
    unit_dirs = np.concatenate([np.eye(box.dim)[active], -np.eye(box.dim)[active]])
    scales = _SCALE ** -np.arange(_SCALES)
    dirs = (scales[:, None, None] * unit_dirs[None]).reshape(-1, box.dim)
    dir_scale = np.repeat(scales, unit_dirs.shape[0])
    step = np.full(x.shape[0], _FIRST_STEP)
    for _ in range(_MAX_POLLS):
        live = step >= _LAST_STEP
        if not live.any():
            break
        idx = np.nonzero(live)[0]
        polls = np.clip(x[idx, None, :] + step[idx, None, None] * dirs[None], 0.0, 1.0)
        k_p, a_p = evaluate(polls.reshape(-1, box.dim))
        evals += k_p.size
        k_p, a_p = k_p.reshape(idx.size, -1), a_p.reshape(idx.size, -1)
        j = np.argmin(k_p, axis=1)
        better = k_p[np.arange(idx.size), j] < fx[idx]
        moved = idx[better]
        x[moved] = polls[better, j[better]]
        fx[moved] = k_p[better, j[better]]
        xa[moved] = a_p[better, j[better]]
        # a move keeps the scale that won (room to grow by one scale); no move shrinks below every scale tried
        step[moved] = np.minimum(_FIRST_STEP, step[moved] * dir_scale[j[better]] * _SCALE)
        step[idx[~better]] *= _SCALE ** -_SCALES
        if (fx <= 0).any():
            break
    return x, fx, xa, evals


def _fresh(box: UncertaintyBox, active: np.ndarray, base: np.ndarray, samples: int, seed: int) -> np.ndarray:
    k = int(active.sum())
    sob = qmc.Sobol(d=k, scramble=True, seed=seed).random_base2(max(1, math.ceil(math.log2(max(samples, 2)))))
    s = np.repeat(base[None, :], sob.shape[0], axis=0)
    s[:, active] = sob
    return s


def minimise_over_box(box: UncertaintyBox, active: np.ndarray, evaluate, *, samples: int = 128, starts: int = 3,
                      seed: int = 0, rounds: int = MAX_ROUNDS) -> tuple[np.ndarray, float, float, int]:
    """Global minimum of a box function given in batches: (unit point, value, its aux value, evaluations).

    ``evaluate(unit_points) -> (values, aux)`` (arrays, one entry per row); a value ≤ 0 stops the search.
    The sample and pattern search of the module doc, then rounds of fresh samples until one finds nothing
    below the best by more than CONVERGED_RTOL.
    """
    unit = _start_points(box, active, samples, seed)
    vals, aux = evaluate(unit)
    evals = unit.shape[0]
    i0 = int(np.argmin(vals))
    best_u, best_v, best_a = unit[i0], float(vals[i0]), float(aux[i0])
    if not (active.any() and best_v > 0):
        return best_u, best_v, best_a, evals
    base = box.to_unit(box.nominal_point())
    for r in range(rounds + 1):
        if r == 0:
            chosen = _distinct(unit, np.argsort(vals), starts)
        else:
            unit = _fresh(box, active, base, samples, seed + 104729 * r)
            vals, aux = evaluate(unit)
            evals += unit.shape[0]
            below = np.nonzero(vals < best_v * (1.0 - CONVERGED_RTOL))[0]
            if below.size == 0:
                break
            chosen = _distinct(unit, below[np.argsort(vals[below])], starts)
        x, fx, xa, n = _pattern(box, active, evaluate, unit[chosen].copy(), vals[chosen].copy(), aux[chosen].copy())
        evals += n
        i = int(np.argmin(fx))
        if fx[i] < best_v:
            best_u, best_v, best_a = x[i], float(fx[i]), float(xa[i])
        if not best_v > 0:
            break
    return best_u, best_v, best_a, evals


def worst_case_stiffness(box: UncertaintyBox, stiffness: float, damping: float, *, samples: int = 128,
                         starts: int = 3, seed: int = 0, rounds: int = MAX_ROUNDS) -> WorstCase:
    """The device of the box with the smallest K_cr(B) (hence the smallest margin of (K, B))."""
    active = box.relevant(STIFFNESS_PATHS)
    best_u, best_k, best_a, evals = minimise_over_box(
        box, active, lambda u: box_critical_stiffness(box, u, damping), samples=samples, starts=starts, seed=seed,
        rounds=rounds)
    point = box.to_box(best_u)
    dev = box.device_at(point)
    freq = best_a / dev.sample_time if math.isfinite(best_a) else None
    margin = 20.0 * math.log10(best_k / stiffness) if best_k > 0 else -math.inf
    return WorstCase(point, dev, best_k, freq, margin, evals)
