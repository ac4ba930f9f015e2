"""Fit one model structure: multistart bounded least squares (scipy.optimize.least_squares, trust-region
reflective, x_scale from the start) with the Jacobian of optim/identification/problem.py.

Rigid: the starts of every whole sample of delay are scored (starts.py); the best few are refined
with the delay bounded to their own sample (the cost is multimodal in the delay, FIELD-NOTES.md), and
the best of those polished with the delay free in [0, max_delay].  Cable: started from the rigid fit
and the resonance read off the data, at the whole samples of delay around the rigid fit's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pydantic import ValidationError
from scipy.optimize import least_squares

from optim.identification.models import POSITIVE, ModelName
from optim.identification.problem import Problem
from optim.identification.starts import cable_starts, rigid_starts

__all__ = ["REFINED_STARTS", "FitOutcome", "fit_model", "refine_friction", "refit_first_half"]

#: whole-sample delay starts refined after scoring (the best by their linear-solve cost)
REFINED_STARTS = 4
_MAX_NFEV = 200
#: passes of the friction regressor read from the fitted model (refine_friction)
FRICTION_PASSES = 3
#: a lower bound (0) is tried as active when the fit ends within this many typical scales of it (for the
#: delay: samples)
_AT_BOUND = 1e-2


@dataclass(frozen=True)
class FitOutcome:
    model: ModelName
    problem: Problem
    x: np.ndarray | None
    rss: float
    jac: np.ndarray | None
    starts: int
    reason: str | None = None
    """why it failed (None when it converged)"""
    last: np.ndarray | None = None
    """where the best run stopped, converged or not (a start for the cable fit)"""


def _bounds(prob: Problem, start: dict[str, float], max_delay: float,
            delay_bounds: tuple[float, float] | None) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = [], []
    for name in prob.names:
        if name == "delay":
            a, b = delay_bounds if delay_bounds is not None else (0.0, max_delay + prob.sample_time)
        elif name == "offset":
            a, b = -np.inf, np.inf
        elif name in POSITIVE:
            a, b = start[name] * 1e-6, start[name] * 1e6
        else:                                    # dampings, friction
            a, b = 0.0, np.inf
        lo.append(a)
        hi.append(b)
    return np.array(lo), np.array(hi)


def _scale(prob: Problem, x: np.ndarray) -> np.ndarray:
    vals = prob.values(x)
    out = []
    for name, v in zip(prob.names, x):
        if name == "offset":
            out.append(max(float(np.std(prob.data.position)), 1e-12))
        else:
            out.append(max(abs(v), prob.typical(name, vals)))
    return np.array(out)


def _solve(prob: Problem, start: dict[str, float], max_delay: float,
           delay_bounds: tuple[float, float] | None = None, max_nfev: int = _MAX_NFEV):
    x0 = np.array([start.get(n, prob.fixed.get(n, 0.0)) for n in prob.names], float)
    lo, hi = _bounds(prob, start, max_delay, delay_bounds)
    x0 = np.clip(x0, lo, np.nextafter(hi, -np.inf))
    scale = _scale(prob, x0)
    return least_squares(prob.residual, x0, jac=lambda x: prob.jacobian(x, lo), bounds=(lo, hi),
                         x_scale=scale, method="trf", max_nfev=max_nfev, xtol=1e-10, ftol=1e-12, gtol=1e-15)


def _polish_at_bounds(prob: Problem, res, max_delay: float):
    """A bound the fit ends near is tried as active: the problem is solved again with those parameters fixed
    at their lower bound (0), and that fit is kept if its cost is not higher.

    The trust-region reflective method approaches a lower bound geometrically and stops on its step tolerance
    a little short of it (seen: a delay of 2e-4 samples for a true 0, the mass 2e-5 off), at a point that
    depends on the rounding of its linear algebra (the OpenBLAS kernel).  With the bound active the rest is
    an interior problem that converges to its own optimum, the same on every kernel (the KKT point).
    """
    x = np.asarray(res.x, float)
    lo, _ = _bounds(prob, dict(zip(prob.names, x)), max_delay, None)
    vals = prob.values(x)
    near = [i for i, n in enumerate(prob.names) if n not in POSITIVE and n != "offset" and lo[i] == 0.0
            and x[i] <= _AT_BOUND * prob.typical(n, vals)]
    if not near:
        return res
    sub = Problem(prob.model, prob.data, {**prob.fixed, **{prob.names[i]: 0.0 for i in near}}, prob.friction,
                  sign_regressor=prob.sign_regressor)
    start = {n: v for n, v in vals.items() if n in sub.names}
    try:
        r = _solve(sub, start, max_delay)
    except (ValidationError, ValueError, ArithmeticError, np.linalg.LinAlgError):
        return res
    finally:
        prob.evaluations += sub.evaluations
    if r.status <= 0 or not np.all(np.isfinite(r.x)) or not r.cost <= res.cost:
        return res
    full = sub.values(r.x)
    r.x = np.array([full[n] for n in prob.names])
    return r


def _start_cost(prob: Problem, start: dict[str, float]) -> float:
    try:
        r = prob.residual(np.array([start.get(n, 0.0) for n in prob.names], float))
    except (ValidationError, ValueError):
        return math.inf
    return float(r @ r)


def fit_model(prob: Problem, max_delay: float, rigid_start: dict[str, float] | None = None) -> FitOutcome:
    """The best least-squares fit of ``prob`` over its starts, or a FitOutcome with its reason."""
    try:
        if prob.model == "rigid":
            scored = rigid_starts(prob, max_delay)
            if not scored:
                return FitOutcome(prob.model, prob, None, math.inf, None, 0,
                                  "no start gave a positive mass: the data do not look like a mass driven by this force")
            runs = [(_solve(prob, s, max_delay, bounds), s) for _, s, bounds in scored[:REFINED_STARTS]]
            best = min(runs, key=lambda r: r[0].cost)[0]
            start = dict(zip(prob.names, best.x))
            final = _polish_at_bounds(prob, _solve(prob, start, max_delay), max_delay)
            n_starts = len(runs) + 1
        else:
            if rigid_start is None:
                raise ValueError("the cable fit starts from a rigid fit")
            starts = cable_starts(prob, rigid_start, max_delay)
            scored = sorted(starts, key=lambda s: _start_cost(prob, s))[:REFINED_STARTS]
            runs = [_solve(prob, s, max_delay) for s in scored]
            final = _polish_at_bounds(prob, min(runs, key=lambda r: r.cost), max_delay)
            n_starts = len(runs)
    except ValidationError as exc:
        err = exc.errors()[0]
        where = ".".join(str(p) for p in err.get("loc", ()))
        return FitOutcome(prob.model, prob, None, math.inf, None, 0,
                          f"the fit left the model's domain ({where}: {err.get('msg', 'invalid')})")
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        return FitOutcome(prob.model, prob, None, math.inf, None, 0,
                          f"the fit broke down numerically ({type(exc).__name__}); the data may be far from this "
                          f"model (check units: N, m, s)")
    if final.status <= 0 or not np.all(np.isfinite(final.x)):
        return FitOutcome(prob.model, prob, None, math.inf, None, n_starts,
                          f"least squares did not converge ({final.message})",
                          final.x if np.all(np.isfinite(final.x)) else None)
    jac = prob.jacobian(final.x, _bounds(prob, dict(zip(prob.names, final.x)), max_delay, None)[0])
    rss = float(final.fun @ final.fun)
    return FitOutcome(prob.model, prob, final.x, rss, jac, n_starts, None, final.x)


def refine_friction(out: FitOutcome, max_delay: float) -> FitOutcome:
    """Re-read the friction's sign from the fitted model instead of the measured position, and refit.

    The sign over [kT, (k+1)T) is that of the model's mean velocity over the sample, x̂[k+1] − x̂[k]: noise
    free, and switching within half a sample of the true reversal on average (the measured-velocity sign
    switches late and flickers with the encoder's noise, worst near a cable mode).  Each pass is kept only
    if it lowers the residual; at most FRICTION_PASSES passes.
    """
    best = out
    for _ in range(FRICTION_PASSES):
        if best.x is None:
            break
        prob = best.problem
        y = prob.output(best.x)
        step = np.zeros(len(y))
        step[:-1] = np.diff(y)
        step[-1] = step[-2] if len(y) > 1 else 0.0
        nxt = Problem(prob.model, prob.data, prob.fixed, True, sign_regressor=-np.sign(step))
        try:
            r = _polish_at_bounds(nxt, _solve(nxt, dict(zip(nxt.names, best.x)), max_delay), max_delay)
        except (ValidationError, ValueError, ArithmeticError, np.linalg.LinAlgError):
            break
        rss = float(r.fun @ r.fun)
        if r.status <= 0 or not np.all(np.isfinite(r.x)) or not rss < best.rss:
            break
        jac = nxt.jacobian(r.x, _bounds(nxt, dict(zip(nxt.names, r.x)), max_delay, None)[0])
        best = FitOutcome(best.model, nxt, r.x, rss, jac, best.starts + 1, None, r.x)
    return best


def refit_first_half(out: FitOutcome, max_delay: float) -> tuple[dict[str, float], dict[str, float]] | None:
    """The model refitted on the first half of a time series, started at the whole record's fit: (estimates,
    standard errors) by name, or None (a frequency response, a fit that fails or leaves the domain).

    The first half starts from rest like the whole record, so it is the same experiment, shorter: its fit
    must agree with the whole one unless the data drift or the model is wrong (misspecification.py)."""
    from optim.identification.data import TimeSeriesData
    from optim.identification.stats import covariance

    prob = out.problem
    if out.x is None or not isinstance(prob.data, TimeSeriesData):
        return None
    h = len(prob.data.force) // 2
    half = TimeSeriesData(prob.sample_time, prob.data.force[:h], prob.data.position[:h])
    sub = Problem(prob.model, half, dict(prob.fixed), prob.friction,
                  sign_regressor=None if prob.sign_regressor is None else prob.sign_regressor[:h])
    try:
        r = _polish_at_bounds(sub, _solve(sub, dict(zip(prob.names, out.x)), max_delay), max_delay)
        if r.status <= 0 or not np.all(np.isfinite(r.x)):
            return None
        jac = sub.jacobian(r.x, _bounds(sub, dict(zip(sub.names, r.x)), max_delay, None)[0])
        cov, _, _ = covariance(jac, float(r.fun @ r.fun))
    except (ValidationError, ValueError, ArithmeticError, np.linalg.LinAlgError):
        return None
    finally:
        prob.evaluations += sub.evaluations
    se = np.sqrt(np.maximum(np.diag(cov), 0.0))
    return dict(zip(sub.names, map(float, r.x))), dict(zip(sub.names, map(float, se)))
