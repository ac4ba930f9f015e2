"""Inverse (hardware) design: the loosest value of one hardware parameter that still renders a target.

The target (optim/hardware/hardware_targets.py) is a wall stiffness K_t and/or a transparency target, the force
gain K_f,t or the apparent mass m_t = m/(1 + K_f) (eq. 28).  For a value q of the free parameter the best
controller is the stiffness design of optim.stiffness (B free up to the optional max_damping, the requested
gain margin), giving the achievable stiffness K*(q), and the inertia design of optim.transparency.inertia (the largest K_f
with the same margin, best over its filter-cutoff band), giving K_f*(q).  The targets hold where every
relative excess (K*/K_t − 1, K_f*/K_f,t − 1, m_t/m_app* − 1) is ≥ 0.  The excesses are scanned on a grid
around the device's own value (the trade-off curve); each target's changes of feasibility between grid points
are refined by Brent's method on its own excess, the targets' feasible sets are intersected (a window between
two targets narrower than a grid step is kept), and the loosest value is the edge of the feasible set in the
direction that makes the hardware cheaper:

    sample_time: larger   delay: larger   damping: smaller
    cable.stiffness: smaller   mass: smaller (a lighter device), except for an apparent-mass target alone:
    the apparent mass grows with m, so that target sets the heaviest device (direction max)

Which parameters move K* (Table 1: K = α·m/T², α depends on δ = bT/m, β = BT/m, d = t_d/T):
with B free, K* = (m/T²)·α*(δ, d) grows with m (the virtual damper can make up
for the physical one), so a target sets the lightest device; with B capped,
K* → g·(b + B_cap)/(T/2 + t_d) (eq. 10) as m grows and mass stops mattering.
K_f* grows with m too (worst case K_f,cr ≈ 1 + m/m_h, eq. 33), but more slowly than m: the apparent mass
m/(1 + K_f*) grows with m.  The answer says so when no achievable quantity changes by more than 0.1 % over the
scanned range.  With a cable block, ``mass`` and ``damping`` scale the cable block's two masses (dampings)
together, keeping their ratio.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.optimize import brentq

from models.device import Device
from optim.errors import InputError
from optim.hardware.hardware_binding import binding_effect
from optim.hardware.hardware_range import check_range, default_grid, range_grid, widen_end
from optim.hardware.hardware_targets import (
    DesignFailed,
    HardwareTarget,
    Probe,
    achievable_force_gain,
    achievable_stiffness,
    device_with,
    limiting_effect,
)

__all__ = ["FREE_PARAMETERS", "HardwareTarget", "HardwareDesign", "design_hardware", "device_with",
           "achievable_stiffness", "achievable_force_gain", "loose_direction"]

#: free parameter → (direction that loosens the hardware, unit)
FREE_PARAMETERS: dict[str, tuple[str, str]] = {
    "sample_time": ("max", "s"), "delay": ("max", "s"), "damping": ("min", "N·s/m"),
    "mass": ("min", "kg"), "cable.stiffness": ("min", "N/m"),
}
_MAX_WIDENINGS = 12     # ×30 steps of one end (optim/hardware/hardware_range.py): 30^12 spans any input limit
_FLAT_RTOL = 1e-3       # achievable values varying less than this over the span: the parameter does not matter
_WHAT = {"stiffness": ("achievable_stiffness", "achievable stiffness"),
         "force_gain": ("achievable_force_gain", "achievable force gain"),
         "apparent_mass": ("apparent_mass", "achievable apparent mass")}


@dataclass(frozen=True)
class HardwareDesign:
    status: Literal["optimal", "infeasible", "failed"]
    free: str
    direction: str
    """max | min: the direction in which the hardware gets looser."""
    value: float | None = None
    """the loosest value of the free parameter that renders the target [SI]; None when it is not limited in the
    scanned range (see bounded) or the target is unreachable."""
    bounded: bool = True
    """False when the target holds up to the end of the scanned range in the loose direction."""
    controller: dict | None = None
    """the best controller at that value: {stiffness, damping, achievable_stiffness, gain_margin_db} for a
    stiffness target, {force_gain, filter_cutoff_hz, filter_order, achievable_force_gain, apparent_mass,
    critical_force_gain, force_gain_margin_db} for a force-feedforward target (None for a target not given)."""
    intervals: tuple[tuple[float, float], ...] = ()
    """the feasible set in the scanned range, as closed intervals [SI]."""
    edges: tuple[dict, ...] = ()
    """every refined edge of the feasible set: [{value, limiting_target}] (the target that binds there)."""
    curve: tuple[dict, ...] = ()
    """trade-off curve: [{value, achievable_stiffness, damping, achievable_force_gain, filter_cutoff_hz,
    apparent_mass}] (achievable_stiffness 0 where nothing is stable; None for a target not given)."""
    best_value: float | None = None
    """where the curve is best: the value with the largest smallest relative excess over the targets."""
    best_achievable_stiffness: float | None = None
    """K* at best_value [N/m]."""
    best_achievable_force_gain: float | None = None
    """K_f* at best_value [dimensionless]."""
    best_apparent_mass: float | None = None
    """m/(1 + K_f*) at best_value [kg]."""
    matters: bool = True
    limiting_target: str | None = None
    """the target that sets the answer: "stiffness" | "force_gain" | "apparent_mass" (None when unbounded)."""
    reason: str | None = None
    note: str | None = None
    limiting_effect: str | None = None
    """the physical effect that sets the answer; for an infeasible answer measured at best_value
    (optim/hardware/hardware_binding.py), since the free parameter has reached a bound there."""
    scanned_range: tuple[float, float] | None = None
    """the range of the free parameter actually scanned [SI]."""
    range_source: str | None = None
    """"request", "default span" or how the default span was widened and what stopped it."""
    elapsed_ms: float = 0.0


def loose_direction(free: str, target: HardwareTarget) -> str:
    """The direction in which the hardware gets looser (module docstring); the velocity filter's cutoff: lower."""
    if free == "velocity_filter.cutoff_hz":
        return "min"
    if free == "mass" and target.stiffness is None and target.feedforward == "apparent_mass":
        return "max"
    return FREE_PARAMETERS[free][0]


def design_hardware(device: Device, target: HardwareTarget, free: str, points: int = 41,
                    value_range: tuple[float, float] | None = None) -> HardwareDesign:
    """The loosest value of ``free`` that still renders ``target`` with the best controller.

    ``value_range`` (min, max) [SI] is scanned as given; without it the default span is widened while the
    target is out of reach and the best value is at an end (optim/hardware/hardware_range.py)."""
    t0 = time.perf_counter()
    from optim.hardware.hardware_cutoff import CUTOFF_FREE, design_cutoff_hardware

    if free == CUTOFF_FREE:
        return design_cutoff_hardware(device, target, points, value_range)
    if free not in FREE_PARAMETERS:
        raise InputError("free", f"must be one of {', '.join(FREE_PARAMETERS)}, {CUTOFF_FREE}")
    if free == "cable.stiffness" and device.cable is None:
        raise InputError("free", "cable.stiffness needs a device with a cable block")
    target.check(device, free)
    direction = loose_direction(free, target)

    def done(**kw) -> HardwareDesign:
        return HardwareDesign(free=free, direction=direction, elapsed_ms=(time.perf_counter() - t0) * 1e3, **kw)

    if value_range is not None:
        check_range(device, free, target, *value_range)
        qs = range_grid(free, *value_range, points)
    else:
        qs = default_grid(device, free, points)
    try:
        return _design(Probe(device, free, target), qs, direction, done, widen=value_range is None)
    except DesignFailed as exc:
        return done(status="failed", reason=str(exc))


def _combined(probe: Probe, q: float) -> float:
    return min(probe.excess(name, q) for name in probe.target.names)


def _widen(probe: Probe, qs: np.ndarray) -> tuple[np.ndarray, dict[int, str]]:
    """The grid widened while no value meets the target, at an end towards which the combined excess still
    grows (the better one first), and what stopped each end (0: lower, -1: upper → reason);
    optim/hardware/hardware_range.py."""
    stops: dict[int, str] = {}
    for _ in range(_MAX_WIDENINGS):
        combined = np.array([_combined(probe, q) for q in qs])
        if (combined >= 0.0).any():
            break
        # an end is widened when it is the best value, or when the excess still rises towards it by more
        # than 1 % of its spread over the scan (not a wiggle: K* is not monotone at long delays)
        best = int(np.argmax(combined))
        spread = float(combined.max() - combined.min())
        rising = {0: best == 0 or combined[0] - combined[1] > 0.01 * spread,
                  -1: best == len(qs) - 1 or combined[-1] - combined[-2] > 0.01 * spread}
        ends = [side for side in (0, -1) if side not in stops and rising[side]]
        if not ends:
            break
        side = max(ends, key=lambda e: combined[e])
        new, stop = widen_end(probe.device, probe.free, probe.target, float(qs[side]), 1 if side else -1,
                              lambda q: _combined(probe, q))
        if stop is not None:
            stops[side] = stop
        qs = np.concatenate([qs, new]) if side else np.concatenate([new[::-1], qs])
    return qs, stops


def _design(probe: Probe, qs: np.ndarray, direction: str, done, widen: bool) -> HardwareDesign:
    target, free = probe.target, probe.free
    span = (float(qs[0]), float(qs[-1]))
    qs, stops = _widen(probe, qs) if widen else (qs, {})
    curve = tuple(probe.curve_entry(q) for q in qs)
    excess = {name: np.array([probe.excess(name, q) for q in qs]) for name in target.names}
    combined = np.min(np.vstack(list(excess.values())), axis=0)
    i_best = int(np.argmax(combined))
    matters, flat = _matters(curve, target)
    common = dict(curve=curve, best_value=float(qs[i_best]), matters=matters, scanned_range=(float(qs[0]),
                  float(qs[-1])), range_source=_range_source(span, qs, stops, widen),
                  best_achievable_stiffness=curve[i_best]["achievable_stiffness"],
                  best_achievable_force_gain=curve[i_best]["achievable_force_gain"],
                  best_apparent_mass=curve[i_best]["apparent_mass"])
    # Each target's own feasible set (Brent on its own excess: only its design runs), then their
    # intersection: a window between two targets narrower than the grid step is still found.
    alone = {name: _feasible_set(probe, name, qs, e) for name, e in excess.items()}
    intervals = [(float(qs[0]), float(qs[-1]), None, None)]
    for name, own in alone.items():
        intervals = _intersect(intervals, own)
    if not intervals:
        limiting = _infeasible_limit(alone, excess, i_best)
        # widened, the free parameter's best is at a bound (physics, input limits, no improvement) or inside
        # the range: moving it cannot help, so its own effect is not the limit; a requested range may be
        effect = binding_effect(probe.device, free, target, float(qs[i_best]), limiting, free_can_move=not widen)
        return done(status="infeasible", reason=_unreachable(probe, qs, i_best, alone, limiting, stops),
                    limiting_target=limiting, limiting_effect=effect, **common)
    edges = sorted(({"value": v, "limiting_target": tag} for lo, hi, tlo, thi in intervals
                    for v, tag in ((lo, tlo), (hi, thi)) if tag is not None), key=lambda e: e["value"])
    loose_end, limiting = (intervals[-1][1], intervals[-1][3]) if direction == "max" else \
        (intervals[0][0], intervals[0][2])
    bounded = limiting is not None
    notes = []
    if not matters:
        notes.append(f"{free} does not matter here: the {flat} changes by less than {_FLAT_RTOL:.0e} relative over "
                     f"[{qs[0]:g}, {qs[-1]:g}]")
    elif len(intervals) > 1:
        notes.append(f"the feasible set is not one interval: {len(intervals)} intervals")
    if not bounded:
        notes.append(f"the target holds up to the end of the scanned range ({free} = {loose_end:g}) in the loose "
                     f"direction")
    return done(status="optimal", value=loose_end if bounded else None, bounded=bounded,
                controller=_controller(probe, loose_end), intervals=tuple((lo, hi) for lo, hi, _, _ in intervals),
                edges=tuple(edges), note="; ".join(notes) or None, limiting_target=limiting,
                limiting_effect=limiting_effect(limiting, free) if bounded else None, **common)


def _feasible_set(probe: Probe, name: str, qs: np.ndarray, excess: np.ndarray) -> list[tuple]:
    """The named target's feasible intervals [(lo, hi, lo_tag, hi_tag)]: a tag names the target at a refined
    edge, None at an end of the scanned range."""
    feasible = excess >= 0.0
    edges = []
    for j in np.nonzero(feasible[:-1] != feasible[1:])[0]:
        lo, hi = float(qs[j]), float(qs[j + 1])
        edges.append(brentq(lambda q: probe.excess(name, q), lo, hi, xtol=1e-14 * max(abs(hi), 1e-300),
                            rtol=4e-15, maxiter=200))
    ends = (float(qs[0]), float(qs[-1]))
    return [(lo, hi, None if lo in ends else name, None if hi in ends else name)
            for lo, hi in _intervals(qs, feasible, edges)]


def _intersect(a: list[tuple], b: list[tuple]) -> list[tuple]:
    """Intersection of two sorted lists of tagged closed intervals; each end keeps the tag of the set it came from."""
    out = []
    for a0, a1, ta0, ta1 in a:
        for b0, b1, tb0, tb1 in b:
            lo, tlo = (a0, ta0) if a0 >= b0 else (b0, tb0)
            hi, thi = (a1, ta1) if a1 <= b1 else (b1, tb1)
            if lo <= hi:
                out.append((lo, hi, tlo, thi))
    return sorted(out, key=lambda iv: iv[0])


def _infeasible_limit(alone: dict, excess: dict, i_best: int) -> str:
    """The target that makes the answer infeasible: one never met on its own (the furthest from reach when
    several), else (each met alone, never together) the one with the smallest excess at the best value."""
    never = [name for name, own in alone.items() if not own]
    if never:
        return min(never, key=lambda n: excess[n].max())
    return min(excess, key=lambda n: excess[n][i_best])


def _matters(curve: tuple[dict, ...], target: HardwareTarget) -> tuple[bool, str]:
    """(does any target's achievable value change by more than _FLAT_RTOL relative over the scan, what is flat)."""
    for name in target.names:
        v = np.array([c[_WHAT[name][0]] for c in curve], dtype=float)
        finite = np.isfinite(v)
        if not finite.all():    # K_f* unbounded somewhere: it matters unless it is unbounded everywhere
            if finite.any():
                return True, _WHAT[name][1]
            continue
        if v.max() > 0 and (v.max() - v.min()) / v.max() > _FLAT_RTOL:
            return True, _WHAT[name][1]
    return False, " and the ".join(_WHAT[n][1] for n in target.names)


def _controller(probe: Probe, q: float) -> dict:
    """The best controller at this value (stiffness part and/or force-feedforward part)."""
    target = probe.target
    out: dict[str, float | None] = {}
    if target.stiffness is not None:
        k, b, d = probe.stiffness(q)
        kt = target.stiffness
        out.update(stiffness=kt, damping=b, achievable_stiffness=k,
                   gain_margin_db=20 * math.log10(d.critical_stiffness / kt) if d.status == "optimal" else None)
    if target.feedforward is not None:
        f = probe.force(q)
        kf = max(target.required_force_gain(f.mass), 0.0)
        margin = None
        if kf > 0 and f.critical_force_gain is not None:
            margin = 20 * math.log10(f.critical_force_gain / kf)
        out.update(force_gain=kf, filter_cutoff_hz=f.filter_cutoff_hz,
                   filter_order=target.inertia_requirements().filter_order, achievable_force_gain=f.force_gain,
                   apparent_mass=f.mass / (1.0 + kf), critical_force_gain=f.critical_force_gain,
                   force_gain_margin_db=margin)
    return out


def _range_source(span: tuple[float, float], qs: np.ndarray, stops: dict[int, str], widen: bool) -> str:
    if not widen:
        return "request"
    text = f"default span [{span[0]:g}, {span[1]:g}]"
    if (float(qs[0]), float(qs[-1])) != span:
        text += f" widened to [{qs[0]:g}, {qs[-1]:g}]"
    return text + "".join(f"; the {'lower' if side == 0 else 'upper'} end stopped by {why}"
                          for side, why in sorted(stops.items()))


def _unreachable(probe: Probe, qs: np.ndarray, i_best: int, alone: dict, limiting: str,
                 stops: dict[int, str]) -> str:
    target, free, q = probe.target, probe.free, float(qs[i_best])
    asked, got = [], []
    if target.stiffness is not None:
        asked.append(f"K = {target.stiffness:g} N/m")
        got.append(f"K* = {probe.stiffness(q)[0]:g} N/m")
    if target.force_gain is not None:
        asked.append(f"K_f = {target.force_gain:g}")
    if target.apparent_mass is not None:
        asked.append(f"apparent mass {target.apparent_mass:g} kg")
    if target.feedforward is not None:
        f = probe.force(q)
        got.append(f"K_f* = {f.force_gain:g} (apparent mass {f.apparent_mass:g} kg)")
    why = (f"{limiting} is not reachable on its own" if not alone[limiting] else
           "each target is reachable alone, but not at the same value: " + "; ".join(
               f"{n} in " + ", ".join(f"[{lo:g}, {hi:g}]" for lo, hi, _, _ in own) for n, own in alone.items()))
    side = 0 if i_best == 0 else -1 if i_best == len(qs) - 1 else None
    where = (f"; {free} cannot go further: {stops[side]}" if side in stops else
             f"; the best {free} lies inside the range" if side is None else "")
    return (f"the target {' and '.join(asked)} is not reachable for any {free} in [{qs[0]:g}, {qs[-1]:g}]: the best "
            f"achievable is {', '.join(got)} at {free} = {q:g}; {why}{where}")


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
