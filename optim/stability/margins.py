"""Critical stiffness K_cr(B) of the sampled haptic loop, exactly (chapter §3.2, eq. 12-13, 20-21).

K_cr(B) is the smallest K > 0 at which the loop 1 + (K + B(1 - z⁻¹)/T)·G(z) = 0
gets a pole on the unit circle (ARCHITECTURE.md), the minimum over every phase
crossover including the Nyquist frequency, and 0 when the loop is unstable as K → 0⁺ (past B_max a band of larger K
may still be stable: optim.stability.stable_band).

Why the minimum over crossovers is the answer: at K = 0⁺ every closed-loop pole
is inside the unit circle provided the damper-only loop 1 + B(1 - z⁻¹)/T·G = 0 is
stable (the pole at z = 1 then moves inwards with K).  That loop is stable for
B below its own critical value B_max, found by the same crossover scan.  Above
B_max the loop is unstable as K → 0⁺: K_cr = 0 with that reason (and the band of larger K that the closed loop
finds stable, if any, in the analysis: optim.stability.stable_band).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import lru_cache
from typing import Literal

import numpy as np

from models.device import Device
from models.discretize import RigidZOH, StateSpaceZOH
from models.plants import stiffness_loop_plant
from optim.errors import InputError
from optim.stability.cable_kernel import cable_min_crossing_compiled as cable_min_crossing
from optim.stability.cable_loop import cable_loop, expm1j, inverse_response_at
from optim.stability.crossovers import Crossing, positive_real_crossings, scan_grid, theta_min
from optim.stability.fast_cable import bounded_min_crossing
from optim.stability.fast_rigid import fast_beta_max, fast_rigid, rigid_loop
from optim.stability.near_b_max import RHO_REFINE, cancellation_ratio, refine_cable_crossover
from optim.stability.reference import REFERENCE_STIFFNESS_MAX_DELAY_SAMPLES
from optim.stability.rigid_levels import rigid_crossovers
from optim.stability.rigid_tail import tail_is_clear
from optim.stability.undamped_cable import (
    NEAR_LOSSLESS_GAP,
    confirm_near_lossless,
    confirm_or_refuse,
    departs_outwards,
    is_undamped_cable,
    mode_gap,
    stable_at_small_k,
    true_crossings,
)
from optim.stability.undamped_cable import refuse as undamped_refusal

__all__ = ["NO_DAMPING_REASON", "Crossover", "CriticalStiffness", "critical_stiffness", "scan_critical_stiffness",
           "critical_from_crossings", "max_stable_damping",
           "linear_estimate", "gain_margin_db", "loop_plant"]

#: Why K_cr = 0 without any damping (δ = β = 0), on every rung: the limit of the linear condition, and the double
#: pole at z = 1 that any K > 0 with the hold's lag drives out of the unit circle.
NO_DAMPING_REASON = ("no physical or virtual damping: no positive stiffness is stable "
                     "(linear condition α < 2(δ+β)/(1+2d) with δ = β = 0)")


@dataclass(frozen=True)
class Crossover:
    """A phase crossover of the loop with the stiffness that puts a pole there."""

    frequency: float
    """ω [rad/s]."""
    stiffness: float
    """K [N/m or N·m/rad] giving a closed-loop pole at e^{jωT}."""


Path = Literal["fast", "bounded-scan", "scan"]


@dataclass(frozen=True)
class CriticalStiffness:
    """K_cr(B) of one device, with every crossover and the reason when it is 0."""

    critical_stiffness: float
    """K_cr [N/m]; 0 when the loop is unstable as K → 0⁺ (optim.stability.stable_band: a larger K may be), inf when
    every K > 0 is."""
    crossover_frequency: float | None
    """ω [rad/s] of the crossover that sets K_cr (None when K_cr is 0 or inf)."""
    all_crossovers: tuple[Crossover, ...] | Callable[[], tuple[Crossover, ...]] = field(repr=False, compare=False)
    """The crossovers, or how to find them: read ``crossovers``."""
    damping: float = 0.0
    """B [N·s/m] the answer is for."""
    max_stable_damping: float | None = None
    """B_max [N·s/m]: with B ≥ B_max no K > 0 is stable (computed only when B > 0)."""
    reason: str | None = None
    method: str = "exact"
    path: Path = "scan"
    """"fast": closed-form brackets and Newton, no scan (rigid: optim.stability.fast_rigid; cable:
    optim.stability.cable_brackets); "bounded-scan" (cable devices where the cable brackets do not close: an
    undamped cable, a zero on the unit circle, pieces unresolved): the scan's grid and brackets, only the
    brackets a bound on |H| cannot exclude solved (optim.stability.fast_cable); "scan": every crossover of a
    frequency scan (optim.stability.crossovers), the fallback wherever the other paths' bounds do not close."""
    unconfirmed: str | None = None
    """Why the closed loop could not confirm this answer (a cable mode within NEAR_LOSSLESS_GAP of the unit circle,
    optim.stability.undamped_cable); the exact rung then claims no error bound.  None: no such doubt."""
    refined_near_b_max: float | None = None
    """A cable near B_max: the cancellation ratio ρ of K_cr = Re H (optim.stability.near_b_max) when the binding
    crossover was re-solved in 40 digits for it (ρ > RHO_REFINE); None otherwise."""

    def __getstate__(self) -> dict:
        # results travel pickled between processes (service.jobs): send the list, never the closure
        return {**self.__dict__, "all_crossovers": self.crossovers}

    @property
    def crossovers(self) -> tuple[Crossover, ...]:
        """All phase crossovers with K > 0, by frequency (the fast path scans for them on first use only)."""
        found = self.all_crossovers
        if callable(found):
            found = found()
            object.__setattr__(self, "all_crossovers", found)
        return found


@lru_cache(maxsize=4096)
def _loop_plant_cached(device: Device):
    return stiffness_loop_plant(device)


#: The last device asked for and its plant, by identity: the LRU cache's key is the Device, whose hash and equality
#: walk its nested pydantic models (≈ 10 µs a call on a cable device, a third of a cable K_cr); a caller that asks
#: again with the same (frozen) object skips both.  One tuple, swapped whole (safe across threads).
_last_plant: tuple = (None, None)


def loop_plant(device: Device):
    """The sampled plant of ``device`` (immutable; cached: a design or a boundary asks for it many times)."""
    global _last_plant
    last = _last_plant
    if last[0] is device:
        return last[1]
    plant = _loop_plant_cached(device)
    _last_plant = (device, plant)
    return plant


def linear_estimate(device: Device, damping: float = 0.0) -> float:
    """K < (b + B)/(T/2 + t_d), chapter eq. 10 [N/m]."""
    return (device.damping + damping) / (device.sample_time / 2 + device.delay)


def gain_margin_db(critical: float, stiffness: float) -> float:
    """20·log10(K_cr/K), chapter eq. 13/21 [dB]."""
    if critical <= 0:
        return -math.inf
    return 20.0 * math.log10(critical / stiffness)


def _theta_min(device: Device, beta: float) -> float:
    """optim.stability.crossovers.theta_min of this device's K loop at β (dimensionless)."""
    return theta_min(device.delta + beta, device.delay_samples)


def _grid(device: Device, plant, beta: float) -> np.ndarray:
    hints = tuple(plant.pole_angles()) + tuple(plant.zero_angles())
    return scan_grid(_theta_min(device, beta), device.delay_samples, hints, width_hint=max(device.delta, 1e-6))


def _damper_crossings(device: Device, plant) -> list[Crossing]:
    def h(theta: np.ndarray) -> np.ndarray:
        return -plant.inverse_response(theta) / (-np.expm1(-1j * theta))
    return positive_real_crossings(h, _grid(device, plant, 0.0))


def max_stable_damping(device: Device) -> float:
    """B_max [N·s/m]: the damper-only loop's critical gain; no K > 0 is stable at or above it."""
    plant = loop_plant(device)
    if is_undamped_cable(device):
        return _undamped_max_stable_damping(device, plant)
    if isinstance(plant, RigidZOH):
        fast = fast_beta_max(plant)
        if fast is not None:
            return fast * device.damping_scale
    if isinstance(plant, StateSpaceZOH) and plant.modal_form() is not None:
        return _cable_b_max(device, plant)[0]
    found = _damper_crossings(device, plant)
    if not found:
        return math.inf
    return min(c.value for c in found) * device.damping_scale


def _cable_b_max(device: Device, plant: StateSpaceZOH) -> tuple[float, Path]:
    """B_max of a cable device with its path: the cable brackets, else the bounded scan (modal form required).

    Kept with the sampled plant (a property of the device alone, as the plant is; loop_plant caches both), so a
    design or a study asking K_cr(B) of one device at many B finds it once."""
    key = ("b_max", device.damping_scale)
    if key not in plant._cache:
        plant._cache[key] = _cable_b_max_uncached(device, plant)
    return plant._cache[key]


def _cable_b_max_uncached(device: Device, plant: StateSpaceZOH) -> tuple[float, Path]:
    # The cable brackets on the damper loop (optim.stability.cable_kernel, compiled; issue 32), where the factored
    # loop is trusted; else, or where they do not close or find no crossover, the bounded scan
    # (optim.stability.fast_cable: the scan's brackets, only the binding one(s) solved), said in the path.  (They
    # answered B_max 7.8e-7 too high on a cable with δ = 1e-9, its damper crossover 4.2e-10 from a resonance 2.4e-11
    # from the unit circle: design property run, seed 17 case 2741, the bounded scan's since cable_loop refused such
    # resonances, and since issue 32 because that crossover is conditioned past cable_loop.MAX_NEAR_ERROR;
    # tests/optim/stability/test_cable_near_b_max.py.)
    loop = cable_loop(plant)
    if loop is not None:
        got = cable_min_crossing(loop, 0.0, _theta_min(device, 0.0), damper=True)
        if got is not None and got[0] is not None:
            return got[0][1] * device.damping_scale, "fast"

    def h(theta: np.ndarray) -> np.ndarray:
        return -plant.inverse_response(theta) / (-np.expm1(-1j * theta))
    best = bounded_min_crossing(h, plant.modal_form(), plant.d, 0.0, _grid(device, plant, 0.0), damper=True)
    return (math.inf if best is None else best[1] * device.damping_scale), "bounded-scan"


def _dead_reason(damping: float, b_max: float) -> str:
    return (f"virtual damping B = {damping:.6g} N·s/m is at or above the largest "
            f"stable virtual damping B_max = {b_max:.6g} N·s/m for this delay: "
            "no positive stiffness is stable")


def critical_stiffness(device: Device, damping: float = 0.0, *, b_max: float | None = None,
                       plant: RigidZOH | StateSpaceZOH | None = None) -> CriticalStiffness:
    """Exact K_cr(B) (the binding crossover refined to double precision, the minimum over all of them).

    Rigid devices take the fast path of optim.stability.fast_rigid, damped cable devices that of
    optim.stability.cable_brackets (``path="fast"``); where their bounds do not close, a cable takes the bounded
    scan (``path="bounded-scan"``), a rigid device every crossover of a scan (``path="scan"``).
    ``b_max``: the caller's ``max_stable_damping(device)`` of this same device, when it has it (a design
    calls this many times on one device); computed here otherwise.  ``plant``: the caller's loop_plant(device) (the
    same numbers: optim.stability.cable_batch hands a row over with its group's sampled plant), else made here."""
    if not (math.isfinite(damping) and damping >= 0.0):
        raise InputError("damping", "virtual damping B must be finite and ≥ 0")
    if plant is None:
        plant = loop_plant(device)
    if device.damping + damping <= 0.0:
        return CriticalStiffness(0.0, None, (), damping, 0.0, reason=NO_DAMPING_REASON)
    if is_undamped_cable(device):
        return _undamped(device, plant, damping)
    if isinstance(plant, RigidZOH):
        fast = _fast(device, plant, damping, b_max)
        if fast is not None:
            return fast
    elif isinstance(plant, StateSpaceZOH) and plant.modal_form() is not None:
        res = _refined_near_b_max(device, plant, damping, _bounded(device, plant, damping, b_max))
        if mode_gap(plant) < NEAR_LOSSLESS_GAP:
            why = confirm_near_lossless(device, damping, res.critical_stiffness)
            if why is not None:
                res = replace(res, unconfirmed=why)
        return res
    return scan_critical_stiffness(device, damping, b_max=b_max)


def _refined_near_b_max(device: Device, plant: StateSpaceZOH, damping: float, res: CriticalStiffness
                        ) -> CriticalStiffness:
    """A cable's K_cr near B_max, where it is a small difference of O(β) terms (cancellation ρ > RHO_REFINE) that the
    double evaluation of the cable's 1/G cannot certify (a 1.15e-4 relative error, on the unsafe side, 9.4e-6 below
    B_max): the binding crossover re-solved in 40 digits (optim.stability.near_b_max).  Where that does not settle
    (or the delay is past the reference's cap) the answer is kept and said unconfirmed: no error bound."""
    k, w, b_max = res.critical_stiffness, res.crossover_frequency, res.max_stable_damping
    if not (damping > 0.0 and b_max is not None and damping > 0.5 * b_max and w is not None
            and math.isfinite(k) and k > 0.0):
        return res
    t, scale = device.sample_time, device.stiffness_scale
    beta, theta, alpha = damping / device.damping_scale, w * t, k / scale
    loop = cable_loop(plant)
    if loop is not None:
        # a screen in Python numbers (≈ 2 µs; numpy's evaluation ≈ 20 µs): the ratio agrees with
        # cancellation_ratio's to ~1e-14, so one at most half the threshold is not refined either way
        quick = (abs(inverse_response_at(loop.modal, loop.d, theta)) + beta * abs(expm1j(-theta))) / alpha
        if quick <= 0.5 * RHO_REFINE:
            return res
    rho = cancellation_ratio(plant, beta, theta, alpha)
    if rho <= RHO_REFINE:
        return res
    got = None
    if device.delay_samples <= REFERENCE_STIFFNESS_MAX_DELAY_SAMPLES:
        got = refine_cable_crossover(device, damping, w * t)
    if got is None:
        return replace(res, unconfirmed=f"near B_max K_cr is a difference of terms {rho:.3g}× larger, and its 40-digit "
                       "re-solve did not settle (or the delay is past the reference rung's cap)")
    theta, alpha = got
    if not alpha > 0.0:
        # in 40 digits the crossover's K is ≤ 0: B is at or above the true B_max, whose double value (the bounded
        # scan's) lies above it by more than B_max − B (2.5e-9 of B_max on a property-run cable): K_cr = 0
        return CriticalStiffness(0.0, None, (), damping, b_max, path=res.path, refined_near_b_max=rho, reason=(
            f"virtual damping B = {damping:.6g} N·s/m is at or above the largest stable virtual damping: the binding "
            f"crossover re-solved in 40 digits has K ≤ 0 (B_max = {b_max:.9g} N·s/m in double precision is above the "
            "true value by more than B_max − B): no positive stiffness is stable"))
    new_k, new_w = alpha * scale, theta / t
    old_list = res.all_crossovers

    def every() -> tuple[Crossover, ...]:
        found = old_list() if callable(old_list) else old_list
        near = min(range(len(found)), key=lambda i: abs(found[i].frequency / new_w - 1.0), default=None)
        if near is None or abs(found[near].frequency / new_w - 1.0) > 1e-9:
            return found
        return found[:near] + (Crossover(new_w, new_k),) + found[near + 1:]

    return replace(res, critical_stiffness=new_k, crossover_frequency=new_w, all_crossovers=every,
                   refined_near_b_max=rho)


def _undamped_damper(device: Device, plant) -> tuple[bool | None, float]:
    """A cable with every damping 0 (optim.stability.undamped_cable): whether B → 0⁺ drives its mode out of the unit
    circle (None: along it), and β₁·m/T, the damper-only loop's first true crossover [N·s/m] (inf when none)."""
    def h(theta: np.ndarray) -> np.ndarray:
        return -plant.inverse_response(theta) / (-np.expm1(-1j * theta))
    modes = [a for a in plant.pole_angles() if a > 0.0]
    if not modes:
        raise undamped_refusal("the cable mode is aliased onto z = 1: whether virtual damping stabilises it cannot "
                               "be decided")
    found = true_crossings(h, positive_real_crossings(h, _grid(device, plant, 0.0)), modes)
    beta1 = min((c.value for c in found), default=math.inf) * device.damping_scale
    return departs_outwards(h, modes[0]), beta1


def _undamped_max_stable_damping(device: Device, plant) -> float:
    outwards, beta1 = _undamped_damper(device, plant)
    if outwards is None:
        raise undamped_refusal("virtual damping moves the cable mode along the unit circle (to double precision): "
                               "the largest stable virtual damping cannot be decided without a given B")
    return 0.0 if outwards else beta1


def _undamped(device: Device, plant, damping: float) -> CriticalStiffness:
    """K_cr(B) of a cable with every damping 0 and B > 0 (optim.stability.undamped_cable: the scan, its false roots
    removed, the answer held to the closed loop or refused)."""
    outwards, beta1 = _undamped_damper(device, plant)
    b_max = None if outwards is None else 0.0 if outwards else beta1
    if outwards and damping < beta1:
        return CriticalStiffness(0.0, None, (), damping, b_max, reason=(
            f"with every cable damping 0 the cable mode is on the unit circle, and virtual damping B = {damping:.6g} "
            "N·s/m drives it outwards through the delay (root-locus departure), below the damper-only loop's first "
            f"crossover at {beta1:.6g} N·s/m: no positive stiffness is stable"))
    if outwards is False and damping >= beta1:
        confirm_or_refuse(device, damping, 0.0)
        return CriticalStiffness(0.0, None, (), damping, b_max, reason=_dead_reason(damping, beta1))
    if outwards is not False and not stable_at_small_k(device, damping):
        # along the circle, or outwards and past β₁: the closed loop at a small K decided it
        return CriticalStiffness(0.0, None, (), damping, b_max, reason=(
            f"with every cable damping 0, virtual damping B = {damping:.6g} N·s/m leaves the cable mode outside the "
            "unit circle (closed-loop eigenvalues at a small K): no positive stiffness is stable"))
    if outwards:
        raise undamped_refusal(f"virtual damping drives the cable mode out below {beta1:.6g} N·s/m and brings it back "
                               f"in at B = {damping:.6g} N·s/m: such a window of stable B is not analysed")
    beta = damping / device.damping_scale

    def h(theta: np.ndarray) -> np.ndarray:
        return -plant.inverse_response(theta) + beta * np.expm1(-1j * theta)

    found = true_crossings(h, positive_real_crossings(h, _grid(device, plant, beta)))
    scale, t = device.stiffness_scale, device.sample_time
    crossovers = _crossover_tuple([(c.angle, c.value) for c in found], t, scale)     # Crossover(θ/T, α·scale)
    if not crossovers:
        confirm_or_refuse(device, damping, math.inf)
        return CriticalStiffness(math.inf, None, (), damping, b_max,
                                 reason="no phase crossover: every positive stiffness is stable")
    best = min(crossovers, key=lambda c: c.stiffness)
    above = [c.stiffness for c in crossovers if c.stiffness > best.stiffness * (1 + 1e-9)]
    confirm_or_refuse(device, damping, best.stiffness, min(above, default=None))
    return CriticalStiffness(best.stiffness, best.frequency, crossovers, damping, b_max)


#: Relative distance below B_max within which a cable's K_cr is taken from the bounded scan, not the brackets.
NEAR_B_MAX = 1e-6


def _bounded(device: Device, plant: StateSpaceZOH, damping: float, b_max: float | None) -> CriticalStiffness:
    """The cable brackets (optim.stability.cable_brackets), else the bounded scan (optim.stability.fast_cable)."""
    beta = damping / device.damping_scale
    if damping > 0.0:
        b_path: Path = "fast"
        if b_max is None:
            b_max, b_path = _cable_b_max(device, plant)
        if damping >= b_max:
            return CriticalStiffness(0.0, None, (), damping, b_max, reason=_dead_reason(damping, b_max),
                                     path=b_path)
    else:
        b_max = None

    def h(theta: np.ndarray) -> np.ndarray:
        return -plant.inverse_response(theta) + beta * np.expm1(-1j * theta)

    loop = cable_loop(plant)
    # Within NEAR_B_MAX of B_max the damper loop's crossover pair nearly touches (H passes beside 0): the brackets
    # have answered "no crossover" there where the scan and the closed loop find one (design property run: B
    # 1e-10–1e-9 below B_max), so that band, and any "no crossover" with B > 0, goes to the bounded scan.
    near_b_max = damping > 0.0 and damping >= b_max * (1.0 - NEAR_B_MAX)
    got = None if loop is None or near_b_max else cable_min_crossing(loop, beta, _theta_min(device, beta))
    if got is not None and (got[0] is not None or damping == 0.0):
        best, path = got[0], "fast"
    else:
        # the cable brackets did not close: the bounded scan, said in ``path``
        best, path = bounded_min_crossing(h, plant.modal_form(), plant.d, beta, _grid(device, plant, beta)), \
            "bounded-scan"

    def every() -> tuple[Crossover, ...]:
        found = scan_critical_stiffness(device, damping, b_max=b_max).crossovers
        if path != "fast" or best is None:
            return found
        # the brackets' binding crossover in place of the scan's (the same one, to the last ulps of K): the
        # list's minimum is K_cr exactly
        w, k = best[0] / device.sample_time, best[1] * device.stiffness_scale
        near = min(range(len(found)), key=lambda i: abs(found[i].frequency - w), default=None)
        if near is None or abs(found[near].frequency / w - 1) > 1e-9:
            raise RuntimeError(f"cable brackets and scan disagree on {device!r}, B = {damping!r}")
        return found[:near] + (Crossover(w, k),) + found[near + 1:]

    if best is None:
        return CriticalStiffness(math.inf, None, (), damping, b_max, path=path,
                                 reason="no phase crossover: every positive stiffness is stable")
    theta, alpha = best
    return CriticalStiffness(alpha * device.stiffness_scale, theta / device.sample_time, every, damping, b_max,
                             path=path)


def _fast(device: Device, plant: RigidZOH, damping: float, b_max: float | None) -> CriticalStiffness | None:
    bs = device.damping_scale
    res = fast_rigid(plant, damping / bs, None if b_max is None or damping == 0.0 else b_max / bs)
    if res is None:
        return None
    bm = None if damping == 0.0 else (b_max if b_max is not None else res.beta_max * bs)
    if res.theta is None:
        return CriticalStiffness(0.0, None, (), damping, bm, reason=_dead_reason(damping, bm), path="fast")
    scale, t, beta = device.stiffness_scale, device.sample_time, damping / bs
    k, w = res.alpha * scale, res.theta / t

    def every() -> tuple[Crossover, ...]:
        found = rigid_crossovers(
            plant, beta, (res.theta, res.alpha), lambda lo: _tail_crossings(device, plant, beta, lo))
        if found is None:
            # the scan's list, its binding entry replaced by the fast path's (the same crossover, to ~1e-15)
            found = [(c.frequency * t, c.stiffness / scale)
                     for c in scan_critical_stiffness(device, damping, b_max=bm).crossovers]
            near = min(range(len(found)), key=lambda i: abs(found[i][0] - res.theta), default=None)
            if near is None or abs(found[near][0] / res.theta - 1) > 1e-9:
                raise RuntimeError(f"fast path and scan disagree on {device!r}, B = {damping!r}")
            found[near] = (res.theta, res.alpha)
        return _crossover_tuple(found, t, scale)

    return CriticalStiffness(k, w, every, damping, bm, path="fast")


def _crossover_tuple(pairs: list[tuple[float, float]], sample_time: float = 1.0,
                     scale: float = 1.0) -> tuple[Crossover, ...]:
    """Crossover(θ/T, α·scale) of each dimensionless pair (θ, α), built without the frozen dataclass's __init__ (one
    object.__setattr__ per field, ≈ 0.9 µs a crossover: a long delay's list holds hundreds): equal instances."""
    new = object.__new__
    out: list[Crossover] = []
    append = out.append
    for th, a in pairs:
        c = new(Crossover)
        fields = c.__dict__
        fields["frequency"] = th / sample_time
        fields["stiffness"] = a * scale
        append(c)
    return tuple(out)


@lru_cache(maxsize=4096)
def _nyquist_parts(plant: RigidZOH) -> tuple[float, float]:
    """(Re 1/G_n(e^{jπ}), Re expm1(−jπ)) as the scan's h samples them at θ = π (a property of the plant: cached as
    loop_plant is; the numpy evaluation costs ≈ 10 µs of a 50 µs analysis)."""
    at_pi = np.array([math.pi])
    return float(plant.inverse_response(at_pi)[0].real), float(np.expm1(-1j * at_pi)[0].real)


def _tail_crossings(device: Device, plant: RigidZOH, beta: float, lo: float) -> list[tuple[float, float]]:
    """(θ, α) of each crossover in [lo, π]: the Nyquist point alone where optim.stability.rigid_tail proves the rest
    of the interval clear (``lo`` is θ_r of that loop), else the scan (optim.stability.crossovers) restricted to it."""
    def h(theta: np.ndarray) -> np.ndarray:
        return -plant.inverse_response(theta) + beta * np.expm1(-1j * theta)

    if lo >= math.pi or tail_is_clear(rigid_loop(plant), beta):
        # nothing in [lo, π) (optim.stability.rigid_tail proves it): only the Nyquist point, as the scan finds it
        # (Re h(π) from the plant's own samples at π, bit for bit: −Re(1/G_n) + β·Re(e^{−jπ} − 1))
        inv_re, em_re = _nyquist_parts(plant)
        v = -inv_re + beta * em_re
        return [(math.pi, v)] if v > 0 else []
    grid = _grid(device, plant, beta)
    grid = np.concatenate([[lo], grid[grid > lo]])
    return [(c.angle, c.value) for c in positive_real_crossings(h, grid)]


def scan_critical_stiffness(device: Device, damping: float = 0.0, *, b_max: float | None = None
                            ) -> CriticalStiffness:
    """K_cr(B) by the scan of every crossover (optim.stability.crossovers): the reference the fast path is held to."""
    if not (math.isfinite(damping) and damping >= 0.0):
        raise InputError("damping", "virtual damping B must be finite and ≥ 0")
    plant = loop_plant(device)
    beta = damping / device.damping_scale
    if device.damping + damping <= 0.0:
        return CriticalStiffness(0.0, None, (), damping, 0.0, reason=NO_DAMPING_REASON)
    if is_undamped_cable(device):
        return _undamped(device, plant, damping)
    if damping > 0.0:
        b_max = max_stable_damping(device) if b_max is None else b_max
    else:
        b_max = None
    if b_max is not None and damping >= b_max:
        return CriticalStiffness(0.0, None, (), damping, b_max, reason=_dead_reason(damping, b_max))

    def h(theta: np.ndarray) -> np.ndarray:
        return -plant.inverse_response(theta) + beta * np.expm1(-1j * theta)

    found = positive_real_crossings(h, _grid(device, plant, beta))
    return critical_from_crossings(device, found, damping, b_max)


def critical_from_crossings(device: Device, found: list[Crossing], damping: float,
                            b_max: float | None) -> CriticalStiffness:
    """K_cr(B) from the positive-real crossings (θ, α) of the loop's h: every one a Crossover (θ/T [rad/s],
    α·stiffness_scale [N/m]), the least of them K_cr; ∞ without one."""
    scale, t = device.stiffness_scale, device.sample_time
    crossovers = _crossover_tuple([(c.angle, c.value) for c in found], t, scale)     # Crossover(θ/T, α·scale)
    if not crossovers:
        return CriticalStiffness(math.inf, None, (), damping, b_max,
                                 reason="no phase crossover: every positive stiffness is stable")
    best = min(crossovers, key=lambda c: c.stiffness)
    return CriticalStiffness(best.stiffness, best.frequency, crossovers, damping, b_max)
