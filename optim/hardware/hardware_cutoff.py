"""Which velocity-filter cutoff renders a target wall: the hardware design with ``free = velocity_filter.cutoff_hz``
(issue 30).

The damper acts on the backward difference followed by a first-order low-pass of cutoff f (models.velocity_filter,
step-invariant).  For each f the best controller is the exact fixed-filter stiffness design
(optim.stiffness.rendered_design: B free up to the target's max_damping, the target's gain margin), giving the
achievable stiffness K*(f).  The target holds where K*(f) ≥ K_t.  K*(f) is scanned on a log grid over the range
(default 1e-3/T … 0.4/T), each change of feasibility refined by Brent's method on K*(f)/K_t − 1 in ln f, and the
answer is the lowest feasible cutoff (direction "min": the most filtering, the least encoder noise on the damper,
that still renders the target).
"""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING

import numpy as np
from scipy.optimize import brentq

from models.device import Device
from optim.errors import InputError
from optim.stability.rendered import rendered_critical_stiffness
from optim.stiffness.rendered_design import FilterContext, best_damping, low_pass_rendering
from optim.stiffness.requirements import MIN_CUTOFF_NU, StiffnessRequirements

if TYPE_CHECKING:
    from optim.hardware.design import HardwareDesign
    from optim.hardware.hardware_targets import HardwareTarget

__all__ = ["CUTOFF_FREE", "design_cutoff_hardware", "DEFAULT_CUTOFF_RANGE"]

CUTOFF_FREE = "velocity_filter.cutoff_hz"
#: default scan (× 1/T)
DEFAULT_CUTOFF_RANGE = (1e-3, 0.4)
_MAX_POINTS = 25


def check_cutoff_range(device: Device, lo: float, hi: float) -> None:
    t = device.sample_time
    if not lo < hi:
        raise InputError("range.min", f"must be below range.max, got min {lo:g} ≥ max {hi:g}")
    if not hi < 0.5 / t:
        raise InputError("range.max", f"must be below the Nyquist frequency 1/(2T) = {0.5 / t:.6g} Hz")
    if not lo * t >= MIN_CUTOFF_NU:
        raise InputError("range.min", f"must be at least {MIN_CUTOFF_NU:g}/T = {MIN_CUTOFF_NU / t:.3g} Hz")


def design_cutoff_hardware(device: Device, target: HardwareTarget, points: int,
                           value_range: tuple[float, float] | None) -> HardwareDesign:
    from optim.hardware.design import HardwareDesign

    t0 = time.perf_counter()
    if target.stiffness is None or target.feedforward is not None:
        raise InputError("free", f"{CUTOFF_FREE} answers a stiffness target alone (the velocity filter does not "
                                 "enter the force-feedforward loop)")
    t = device.sample_time
    lo, hi = value_range if value_range is not None else (DEFAULT_CUTOFF_RANGE[0] / t, DEFAULT_CUTOFF_RANGE[1] / t)
    check_cutoff_range(device, lo, hi)
    req = StiffnessRequirements(min_gain_margin_db=target.min_gain_margin_db, passivity=False,
                                max_damping=target.max_damping)
    ctx = FilterContext(device, req, 0.0, req.stiffness_caps(), req.gain_factor)
    kt = target.stiffness
    memo: dict[float, tuple[float, float]] = {}

    def best(f: float) -> tuple[float, float]:
        if f not in memo:
            b, k, _, _ = best_damping(ctx, low_pass_rendering(1, f, t, 0.0), points=13, zoom_rounds=3, polish=False, brackets=2)
            memo[f] = (max(k, 0.0) if math.isfinite(k) or k > 0 else 0.0, b)
        return memo[f]

    def excess(u: float) -> float:
        return best(math.exp(u))[0] / kt - 1.0

    fs = np.geomspace(lo, hi, min(points, _MAX_POINTS))
    ex = np.array([excess(math.log(f)) for f in fs])
    curve = tuple({"value": float(f), "achievable_stiffness": best(float(f))[0], "damping": best(float(f))[1],
                   "achievable_force_gain": None, "filter_cutoff_hz": float(f), "apparent_mass": None} for f in fs)
    edges, intervals, start = [], [], (float(fs[0]) if ex[0] >= 0 else None)
    for i in range(fs.size - 1):
        if (ex[i] >= 0) != (ex[i + 1] >= 0):
            u = brentq(excess, math.log(fs[i]), math.log(fs[i + 1]), xtol=1e-9)
            f = math.exp(u)
            # the edge on the feasible side
            f = f if excess(u) >= 0 else (f * (1 + 1e-9) if ex[i + 1] >= 0 else f * (1 - 1e-9))
            edges.append({"value": f, "limiting_target": "stiffness"})
            if ex[i + 1] >= 0:
                start = f
            elif start is not None:
                intervals.append((start, f))
                start = None
    if start is not None:
        intervals.append((start, float(fs[-1])))
    j = int(np.argmax(ex))
    common = dict(free=CUTOFF_FREE, direction="min", curve=curve, best_value=float(fs[j]),
                  best_achievable_stiffness=best(float(fs[j]))[0], scanned_range=(lo, hi),
                  range_source="request" if value_range is not None else "default span 1e-3/T … 0.4/T",
                  edges=tuple(edges), intervals=tuple(intervals),
                  note="a first-order (step-invariant) low-pass on the backward difference; the lowest cutoff is the "
                       "most filtering (least encoder noise on the damper) that still renders the target")
    if not intervals:
        return HardwareDesign(status="infeasible", limiting_target="stiffness", reason=(
            f"no cutoff in [{lo:.6g}, {hi:.6g}] Hz renders K = {kt:g} N/m with {target.min_gain_margin_db:g} dB: the "
            f"best is {best(float(fs[j]))[0]:.6g} N/m at {fs[j]:.6g} Hz"),
            elapsed_ms=(time.perf_counter() - t0) * 1e3, **common)  # type: ignore[arg-type]
    value = intervals[0][0]
    bounded = value > lo
    k_star, b = best(value)
    kcr = rendered_critical_stiffness(device, b, low_pass_rendering(1, value, t, 0.0)).critical_stiffness
    controller = {"stiffness": kt, "damping": b, "achievable_stiffness": k_star,
                  "gain_margin_db": 20 * math.log10(kcr / kt) if kcr > 0 and math.isfinite(kcr) else None,
                  "filter_cutoff_hz": value, "filter_order": 1}
    return HardwareDesign(status="optimal", value=value if bounded else None, bounded=bounded, controller=controller,
                          limiting_target="stiffness" if bounded else None,
                          elapsed_ms=(time.perf_counter() - t0) * 1e3, **common)  # type: ignore[arg-type]
