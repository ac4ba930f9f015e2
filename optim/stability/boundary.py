"""The stability boundary K_cr(B) of a device (chapter §3.2, Fig. 5 and 9) and its optimum."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from models.device import Device
from models.velocity_filter import Rendering
from optim.errors import NOT_REPRESENTABLE, InputError
from optim.stability.margins import critical_stiffness, linear_estimate, max_stable_damping
from optim.stability.rendered import rendered_critical_stiffness, rendered_max_stable_damping

__all__ = ["BoundaryPoint", "Boundary", "stability_boundary", "MAX_BOUNDARY_POINTS"]

#: Cost limit: points on one boundary request.
MAX_BOUNDARY_POINTS = 2000


@dataclass(frozen=True)
class BoundaryPoint:
    damping: float
    """B [N·s/m]."""
    critical_stiffness: float
    """K_cr(B) [N/m] (0 at and above B_max)."""
    crossover_frequency: float | None
    """ω [rad/s] of the crossover that sets K_cr."""
    linear_estimate: float
    """(b + B)/(T/2 + t_d) [N/m], eq. 10."""


@dataclass(frozen=True)
class Boundary:
    points: tuple[BoundaryPoint, ...]
    optimum: BoundaryPoint
    """The B that allows the stiffest stable wall, refined between grid points."""
    max_stable_damping: float | None
    """B_max [N·s/m]; None when no finite limit exists."""
    elapsed_ms: float


def _kcr(device: Device, b: float, b_max: float, rendering: Rendering | None):
    if rendering is None or rendering.is_default:
        return critical_stiffness(device, b, b_max=b_max)     # B_max once per boundary, not once per point
    return rendered_critical_stiffness(device, b, rendering)


def _point(device: Device, b: float, b_max: float, rendering: Rendering | None = None) -> BoundaryPoint:
    r = _kcr(device, b, b_max, rendering)
    k = r.critical_stiffness if math.isfinite(r.critical_stiffness) else math.nan
    return BoundaryPoint(b, k, r.crossover_frequency, linear_estimate(device, b))


def stability_boundary(device: Device, damping_max: float | None = None, points: int = 50,
                       rendering: Rendering | None = None) -> Boundary:
    """K_cr(B) on ``points`` values of B from 0 to ``damping_max`` (default: B_max), for today's wall or the
    ``rendering`` (velocity filter and virtual mass: optim.stability.rendered; B_max at its M).

    Raises ValueError (naming the field) for bad arguments or unrepresentable devices.
    """
    try:
        with np.errstate(over="raise", invalid="raise"):
            return _boundary(device, damping_max, points, rendering)
    except (FloatingPointError, OverflowError, ZeroDivisionError) as exc:
        raise InputError("device", NOT_REPRESENTABLE) from exc


def _boundary(device: Device, damping_max: float | None, points: int, rendering: Rendering | None) -> Boundary:
    if not (2 <= points <= MAX_BOUNDARY_POINTS):
        raise InputError("points", f"must be between 2 and {MAX_BOUNDARY_POINTS}")
    if damping_max is not None and not (math.isfinite(damping_max) and damping_max > 0):
        raise InputError("damping_max", "must be finite and > 0")
    t0 = time.perf_counter()
    b_max = (max_stable_damping(device) if rendering is None or rendering.is_default
             else rendered_max_stable_damping(device, rendering))
    top = damping_max if damping_max is not None else b_max
    if top == 0.0:
        raise InputError("damping_max", "no B > 0 is stable with this virtual mass and velocity filter (B_max = 0)")
    if not math.isfinite(top):
        raise InputError("damping_max", "this device has no finite B_max; give damping_max")
    grid = np.linspace(0.0, top, points)
    pts = tuple(_point(device, float(b), b_max, rendering) for b in grid)
    valid = [p for p in pts if math.isfinite(p.critical_stiffness)]
    best_i = int(np.argmax([p.critical_stiffness for p in valid]))
    lo = valid[max(best_i - 1, 0)].damping
    hi = valid[min(best_i + 1, len(valid) - 1)].damping
    best = valid[best_i]
    if hi > lo:
        res = minimize_scalar(lambda b: -_kcr(device, b, b_max, rendering).critical_stiffness,
                              bounds=(lo, hi), method="bounded", options={"xatol": 1e-10 * max(hi, 1e-300)})
        cand = _point(device, float(res.x), b_max, rendering)
        if cand.critical_stiffness > best.critical_stiffness:
            best = cand
    return Boundary(pts, best, b_max if math.isfinite(b_max) else None, (time.perf_counter() - t0) * 1e3)
