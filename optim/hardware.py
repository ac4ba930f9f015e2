"""Inverse (hardware) design: the loosest value of one hardware parameter that still renders a target wall.

For a value q of the free parameter the best controller is the stiffness design
of optim.stiffness (B free up to the optional max_damping, the requested gain
margin), giving the achievable stiffness K*(q).  The target is reachable where
K*(q) ≥ K_target.  K*(q) is scanned on a grid around the device's own value
(the trade-off curve), every change of feasibility between grid points is
refined by Brent's method on K*(q) − K_target, and the loosest value is the edge
of the feasible set in the direction that makes the hardware cheaper:

    sample_time: larger   delay: larger   damping: smaller
    cable.stiffness: smaller   mass: smaller (a lighter device)

Which parameters move K* (Table 1: K = α·m/T², α depends on δ = bT/m, β = BT/m, d = t_d/T):
with B free, K* = (m/T²)·α*(δ, d) grows with m (the virtual damper can make up
for the physical one), so a target sets the lightest device; with B capped,
K* → g·(b + B_cap)/(T/2 + t_d) (eq. 10) as m grows and mass stops mattering.
The answer says so when K* changes by less than 0.1 % over the scanned range.
With a cable block, ``mass`` and ``damping`` scale the cable block's two masses
(dampings) together, keeping their ratio.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq

from models.device import MAX_DELAY_SAMPLES, Device
from optim.stiffness import StiffnessRequirements, design_stiffness

__all__ = ["FREE_PARAMETERS", "HardwareTarget", "HardwareDesign", "design_hardware", "device_with",
           "achievable_stiffness"]

#: free parameter → (direction that loosens the hardware, unit)
FREE_PARAMETERS: dict[str, tuple[str, str]] = {
    "sample_time": ("max", "s"), "delay": ("max", "s"), "damping": ("min", "N·s/m"),
    "mass": ("min", "kg"), "cable.stiffness": ("min", "N/m"),
}
_SPAN = 30.0            # the curve spans value/30 … value·30 (log scale)
_FLAT_RTOL = 1e-3       # K* varying less than this over the span: the parameter does not matter


@dataclass(frozen=True)
class HardwareTarget:
    stiffness: float
    """K the device must render [N/m]."""
    min_gain_margin_db: float = 6.0
    max_damping: float | None = None
    """optional cap on the virtual damping B [N·s/m]."""

    def requirements(self) -> StiffnessRequirements:
        return StiffnessRequirements(min_gain_margin_db=self.min_gain_margin_db, max_damping=self.max_damping)


@dataclass(frozen=True)
class HardwareDesign:
    status: str
    """optimal | infeasible | failed."""
    free: str
    direction: str
    """max | min: the direction in which the hardware gets looser."""
    value: float | None = None
    """the loosest value of the free parameter that renders the target [SI]; None when it is not limited in the
    scanned range (see bounded) or the target is unreachable."""
    bounded: bool = True
    """False when the target holds up to the end of the scanned range in the loose direction."""
    controller: dict | None = None
    """{stiffness, damping, gain_margin_db} of the best controller at that value."""
    intervals: tuple[tuple[float, float], ...] = ()
    """the feasible set in the scanned range, as closed intervals [SI]."""
    curve: tuple[dict, ...] = ()
    """trade-off curve: [{value, achievable_stiffness, damping}] (achievable_stiffness 0 where nothing is stable)."""
    best_value: float | None = None
    """where the curve peaks: the value with the largest achievable stiffness."""
    best_achievable_stiffness: float | None = None
    matters: bool = True
    reason: str | None = None
    note: str | None = None
    limiting_effect: str | None = None
    elapsed_ms: float = 0.0


def _set(data: dict, path: str, value: float) -> None:
    parts = path.split(".")
    for key in parts[:-1]:
        data = data[key]
    data[parts[-1]] = value


def device_with(device: Device, free: str, value: float) -> Device:
    """The device with the free parameter set to ``value`` (validated)."""
    data = device.model_dump()
    data["preset"] = None
    cable = data.get("cable")
    if cable is not None:
        data.pop("mass")
        data.pop("damping")
        if free in ("mass", "damping"):
            a, b = f"motor_{free}", f"body_{free}"
            total = cable[a] + cable[b]
            ratio = value / total if total > 0 else 0.0
            cable[a], cable[b] = cable[a] * ratio, cable[b] * ratio
            return Device.model_validate(data)
    _set(data, free, float(value))
    return Device.model_validate(data)


def _current(device: Device, free: str) -> float:
    obj = device
    for key in free.split("."):
        obj = getattr(obj, key)
    return float(obj)


def achievable_stiffness(device: Device, free: str, value: float, target: HardwareTarget):
    """(K*, B*, design) of the best controller for the device with the free parameter at value."""
    d = design_stiffness(device_with(device, free, value), target.requirements())
    if d.status == "optimal":
        return d.stiffness, d.damping, d
    return 0.0, None, d


def _grid(device: Device, free: str, points: int) -> np.ndarray:
    v = _current(device, free)
    if free == "delay":
        hi = max(30 * device.sample_time, 30 * v)
        hi = min(hi, 0.5 * MAX_DELAY_SAMPLES * device.sample_time)
        return np.linspace(0.0, hi, points)
    if free == "sample_time":
        hi = min(_SPAN * v, 1.0)
        if device.delay > 0:
            hi = min(hi, 1.0)
        lo = max(v / _SPAN, device.delay / MAX_DELAY_SAMPLES * 2)
        return np.geomspace(lo, hi, points)
    if v <= 0:
        raise ValueError(f"free: the device's {free} is 0; give a positive value to scan around")
    return np.geomspace(v / _SPAN, v * _SPAN, points)


def design_hardware(device: Device, target: HardwareTarget, free: str, points: int = 41) -> HardwareDesign:
    """The loosest value of ``free`` that still renders ``target`` with the best controller."""
    t0 = time.perf_counter()
    if free not in FREE_PARAMETERS:
        raise ValueError(f"free: must be one of {', '.join(FREE_PARAMETERS)}")
    if free == "cable.stiffness" and device.cable is None:
        raise ValueError("free: cable.stiffness needs a device with a cable block")
    if not (math.isfinite(target.stiffness) and target.stiffness > 0):
        raise ValueError("target.stiffness: must be a finite number > 0")
    direction = FREE_PARAMETERS[free][0]
    qs = _grid(device, free, points)
    ks, bs, status = [], [], []
    for q in qs:
        k, b, d = achievable_stiffness(device, free, float(q), target)
        ks.append(k)
        bs.append(b)
        status.append(d.status)
    ks = np.array(ks)
    if "failed" in status:
        bad = float(qs[status.index("failed")])
        return HardwareDesign(status="failed", free=free, direction=direction,
                              reason=f"the stiffness design failed at {free} = {bad:g}",
                              elapsed_ms=(time.perf_counter() - t0) * 1e3)
    curve = tuple({"value": float(q), "achievable_stiffness": float(k), "damping": b} for q, k, b in zip(qs, ks, bs))
    i_best = int(np.argmax(ks))
    spread = (ks.max() - ks.min()) / ks.max() if ks.max() > 0 else 0.0
    matters = bool(spread > _FLAT_RTOL)
    common = dict(free=free, direction=direction, curve=curve, best_value=float(qs[i_best]),
                  best_achievable_stiffness=float(ks[i_best]), matters=matters)
    kt = target.stiffness
    feasible = ks >= kt

    def excess(q: float) -> float:
        return achievable_stiffness(device, free, q, target)[0] - kt

    edges = []
    for j in np.nonzero(feasible[:-1] != feasible[1:])[0]:
        lo, hi = float(qs[j]), float(qs[j + 1])
        edges.append(brentq(excess, lo, hi, xtol=1e-14 * max(abs(hi), 1e-300), rtol=4e-15, maxiter=200))
    intervals = _intervals(qs, feasible, edges)
    if not intervals:
        effect = _limiting_effect(free, direction)
        return HardwareDesign(status="infeasible", intervals=(), reason=(
            f"the target K = {kt:g} N/m is not reachable for any {free} in [{qs[0]:g}, {qs[-1]:g}]: the best "
            f"achievable is {ks[i_best]:g} N/m at {free} = {qs[i_best]:g}"), limiting_effect=effect,
            elapsed_ms=(time.perf_counter() - t0) * 1e3, **common)
    loose_end = intervals[-1][1] if direction == "max" else intervals[0][0]
    range_end = float(qs[-1]) if direction == "max" else float(qs[0])
    bounded = loose_end != range_end
    note = None
    if not matters:
        note = (f"{free} does not matter here: the achievable stiffness changes by less than "
                f"{_FLAT_RTOL:.0e} relative over [{qs[0]:g}, {qs[-1]:g}]")
    elif len(intervals) > 1:
        note = f"the feasible set is not one interval: {len(intervals)} intervals"
    if not bounded:
        extra = (f"the target holds up to the end of the scanned range ({free} = {range_end:g}) in the loose "
                 f"direction")
        note = extra if note is None else note + "; " + extra
    value = loose_end if bounded else None
    controller = None
    at = loose_end
    k, b, d = achievable_stiffness(device, free, at, target)
    if d.status == "optimal":
        controller = {"stiffness": kt, "damping": b, "achievable_stiffness": k,
                      "gain_margin_db": 20 * math.log10(d.critical_stiffness / kt)}
    return HardwareDesign(status="optimal", value=value, bounded=bounded, controller=controller,
                          intervals=tuple(intervals), note=note, limiting_effect=_limiting_effect(free, direction),
                          elapsed_ms=(time.perf_counter() - t0) * 1e3, **common)


def _intervals(qs: np.ndarray, feasible: np.ndarray, edges: list[float]) -> list[tuple[float, float]]:
    out, start, e = [], (float(qs[0]) if feasible[0] else None), iter(edges)
    for j in range(len(qs) - 1):
        if feasible[j] != feasible[j + 1]:
            x = next(e)
            if feasible[j]:
                out.append((start, x))
                start = None
            else:
                start = x
    if start is not None:
        out.append((start, float(qs[-1])))
    return out


def _limiting_effect(free: str, direction: str) -> str:
    return {
        "sample_time": "sampling: the zero-order hold's half-sample lag (eq. 10: K < (b+B)/(T/2 + t_d))",
        "delay": "loop delay: its phase lag (eq. 10: K < (b+B)/(T/2 + t_d))",
        "damping": "physical damping: the dissipation that pays for the sampled loop's energy leak (eq. 10)",
        "mass": "mass: with less inertia the virtual damper destabilises sooner (Table 1: β = BT/m, α = KT²/m)",
        "cable.stiffness": "the cable's vibration mode: its resonance moves toward the crossover (§4, eq. 22-24)",
    }[free]
