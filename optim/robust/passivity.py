"""Passivity over an uncertainty box: the finitely many devices that decide it, found exactly (no search).

Passivity of (K, B) on a device (ARCHITECTURE.md, optim.stability.passivity) reads

    b > P(θ) = (K·T/2)·s_n(θ) − B·cos((n+1)θ)   for every θ ∈ (0, π],   n = ⌈t_d/T⌉,

so it depends on the device through (b, T, n) alone: the mass, the cable's spring and
damper, the grasp and the sensor do not enter.  Over a box:

* b enters only on the left: the worst device has the smallest b (b, or b_r + b_d
  with a cable block, at the lower ends of its ranges);
* n = ⌈t_d/T⌉ is piecewise constant and jumps: n is reached exactly for
  T ∈ [t_d,min/n, t_d,max/(n−1)) ∩ [T_min, T_max] (some t_d of its range in
  ((n−1)T, nT]), an interval for each whole n between ⌈t_d,min/T_max⌉ and
  ⌈t_d,max/T_min⌉;
* for a fixed n and θ, P is linear in T, so over each interval the worst T is one of
  its two ends.

The box is therefore passive for (K, B) iff each of these *passivity corners*
(b_min, T_end, n) is, with the closure of each T interval: where the interval is open at
T = t_d,max/(n−1) (there the delay is a whole n − 1 samples), the devices just below it
have n samples, and their passivity tends to the corner's (the passive set is strict, its
supremum is the same).  Such a corner is ``approached``, not attained, by the box.

A fractional delay is rounded up to the next whole sample (conservative), as in
optim.stability.passivity.  The number of whole delays a box allows is capped (each is a corner).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models.device import Device
from models.discretize import split_delay
from optim.errors import InputError
from optim.robust.box import UncertaintyBox
from optim.stability.passivity import PassivityCheck, largest_passive_stiffness, passivity_margin, passivity_samples

__all__ = ["PASSIVITY_PATHS", "MAX_PASSIVITY_DELAYS", "PassivityCorner", "PassivityWorst", "passivity_corners",
           "worst_passivity", "largest_robust_passive_stiffness", "describe_delays"]

#: the paths passivity depends on: the physical damping b (or b_r + b_d), T and t_d
PASSIVITY_PATHS = frozenset({"device.damping", "device.cable.motor_damping", "device.cable.body_damping",
                             "device.sample_time", "device.delay"})
_DAMPING_PATHS = ("device.damping", "device.cable.motor_damping", "device.cable.body_damping")
#: at most this many whole-sample delays n = ⌈t_d/T⌉ over the box (two corners each)
MAX_PASSIVITY_DELAYS = 64


@dataclass(frozen=True)
class PassivityCorner:
    """One (b, T, n) that passivity over the box must hold for."""

    damping: float
    """b [N·s/m]: the smallest physical damping of the box."""
    sample_time: float
    """T [s]."""
    delay_samples: int
    """n: whole samples of delay the test uses (⌈t_d/T⌉)."""
    point: np.ndarray
    """box values of the device that has it (or approaches it), order of box.paths."""
    approached: bool
    """True when no device of the box has exactly (T, n): the devices with T just below it do."""
    device: Device
    """a rigid device with exactly (b, T, n) (mass irrelevant): what optim.stability.passivity evaluates."""


def _ceil_samples(ratio: float) -> int:
    whole, frac = split_delay(ratio)
    return whole + 1 if frac > 0 else whole


def _range(box: UncertaintyBox, path: str, nominal: float) -> tuple[float, float]:
    if path in box.paths:
        k = box.paths.index(path)
        return float(box.lower[k]), float(box.upper[k])
    return nominal, nominal


def passivity_corners(box: UncertaintyBox, field: str = "requirements.uncertainty") -> list[PassivityCorner]:
    """Every passivity corner of the box (see the module docstring), smallest n first."""
    nom = box.nominal
    t_lo, t_hi = _range(box, "device.sample_time", nom.sample_time)
    d_lo, d_hi = _range(box, "device.delay", nom.delay)
    n_lo, n_hi = _ceil_samples(d_lo / t_hi), _ceil_samples(d_hi / t_lo)
    if n_hi - n_lo + 1 > MAX_PASSIVITY_DELAYS:
        raise InputError(field, f"a robust design with passivity checks every whole-sample delay ⌈t_d/T⌉ the box "
                         f"allows, here {n_lo} to {n_hi}; at most {MAX_PASSIVITY_DELAYS} (narrow the ranges of "
                         "device.delay or device.sample_time)")
    base = box.nominal_point()
    for path in _DAMPING_PATHS:
        if path in box.paths:
            base[box.paths.index(path)] = box.lower[box.paths.index(path)]
    b_min = box.device_at(base).damping
    corners: list[PassivityCorner] = []
    for n in range(n_lo, n_hi + 1):
        if n == 0:
            if d_lo > 0.0:
                continue
            ends = (t_lo, t_hi)
        else:
            # some t_d in [d_lo, d_hi] with n − 1 < t_d/T ≤ n: T ≥ d_lo/n and T < d_hi/(n − 1)
            a = max(t_lo, d_lo / n)
            b = t_hi if n == 1 else min(t_hi, d_hi / (n - 1))
            if a > b:
                continue
            ends = (a, b)
        for t_end in sorted(set(ends)):
            corners.append(_corner(box, base, b_min, t_end, n, d_lo, d_hi))
    return corners


def _corner(box: UncertaintyBox, base: np.ndarray, b_min: float, t_end: float, n: int,
            d_lo: float, d_hi: float) -> PassivityCorner:
    delay = 0.0 if n == 0 else min(n * t_end, d_hi)
    point = base.copy()
    if "device.sample_time" in box.paths:
        point[box.paths.index("device.sample_time")] = t_end
    if "device.delay" in box.paths:
        point[box.paths.index("device.delay")] = min(max(delay, d_lo), d_hi)
    real = box.device_at(point)
    approached = passivity_samples(real)[0] != n
    device = Device(mass=box.nominal.mass, damping=b_min, sample_time=t_end, delay=n * t_end)
    if passivity_samples(device)[0] != n:            # n·T/T is n to within 64 ulp (split_delay)
        raise ArithmeticError(f"passivity corner: delay {n * t_end:g} s over {t_end:g} s is not {n} samples")
    return PassivityCorner(b_min, t_end, n, point, approached, device)


@dataclass(frozen=True)
class PassivityWorst:
    corner: PassivityCorner
    check: PassivityCheck
    margin: float
    """b − sup_θ P(θ) [N·s/m]: ≥ 0 when passive (≈ 0 when passivity binds: the design sits on the supremum)."""


def worst_passivity(corners: list[PassivityCorner], stiffness: float, damping: float) -> PassivityWorst:
    """The corner with the smallest passivity margin b − sup P at (K, B)."""
    best: PassivityWorst | None = None
    for c in corners:
        check = passivity_margin(c.device, stiffness, damping)
        margin = c.damping - check.required_damping
        if best is None or margin < best.margin:
            best = PassivityWorst(c, check, margin)
    if best is None:
        raise ValueError("worst_passivity needs at least one corner")
    return best


def largest_robust_passive_stiffness(corners: list[PassivityCorner], damping: float) -> tuple[float, int]:
    """(sup of K passive on every corner at B [N/m], index of the corner that sets it)."""
    ks = [largest_passive_stiffness(c.device, damping).stiffness for c in corners]
    i = int(np.argmin(ks))
    return float(ks[i]), i


def describe_delays(corners: list[PassivityCorner]) -> str:
    """The whole-sample delays the corners cover, e.g. "1 to 3"."""
    ns = sorted({c.delay_samples for c in corners})
    return (f"{ns[0]} sample" + ("" if ns[0] == 1 else "s")) if len(ns) == 1 else f"{ns[0]} to {ns[-1]} samples"
