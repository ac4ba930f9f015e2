"""The range the inverse (hardware) design scans: the default span, a requested range, and its widening.

By default the scan spans value/30 … value·30 (the delay 0 … 30 samples).  When no value there meets the
target and the best one is at an end, that end is widened (×30 per step) until the target is reached or a
bound stops it: a physical bound (a delay of 0), an input limit of the device (models/device.py: masses,
dampings and stiffnesses ≤ 1e12, T ≤ 1 s, at most MAX_DELAY_SAMPLES samples of delay) or of the numeric domain
(optim/domain.py, docs/limits.md: δ = bT/m ≤ 1e9, α = K·T²/m within [1e-30, 1e30], …), or the target's
excess no longer improving.  The last allowed value before a limit is found by bisection (log scale).  A
requested ``range`` {min, max} is scanned as given and never widened.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np
from pydantic import ValidationError

from models.device import MAX_DELAY_SAMPLES, Device
from optim.domain import check_controller_domain, check_cutoff_domain, check_device_domain
from optim.errors import InputError
from optim.hardware.hardware_targets import HardwareTarget, current_value, device_with

__all__ = ["default_grid", "range_grid", "check_range", "refusal", "widen_end", "SPAN"]

SPAN = 30.0             # the default scan spans value/30 … value·30 (log scale)
_WIDEN = 30.0           # each widening step moves the end by this factor
_WIDEN_POINTS = 8       # grid points added per step
_LIMIT_BISECTIONS = 60  # log-scale bisection for the last allowed value


def refusal(device: Device, free: str, value: float, target: HardwareTarget) -> str | None:
    """Why the device with ``free`` = value is outside the input limits ("field: rule"), or None."""
    if not (math.isfinite(value) and value >= 0.0) or (free != "delay" and value <= 0.0):
        return f"{free}: must be {'≥ 0' if free == 'delay' else '> 0'}, got {value:g}"
    try:
        dev = device_with(device, free, value)
        check_device_domain(dev)
        if target.stiffness is not None:
            check_controller_domain(target.stiffness, dev, "stiffness", "target.stiffness")
        if target.max_damping is not None:
            check_controller_domain(target.max_damping, dev, "damping", "target.max_damping")
        if target.feedforward is not None and target.cutoff_min_hz is not None:
            check_cutoff_domain(target.cutoff_min_hz, dev.sample_time, "target.cutoff_min_hz")
    except ValidationError as exc:
        err = exc.errors()[0]
        loc = ".".join(str(p) for p in err["loc"]) or free
        return f"{loc}: {err['msg'].removeprefix('Value error, ')}"
    except ValueError as exc:
        return str(exc)
    return None


def default_grid(device: Device, free: str, points: int) -> np.ndarray:
    """The default scan around the device's own value (module docstring)."""
    v = current_value(device, free)
    if free == "delay":
        hi = max(SPAN * device.sample_time, SPAN * v)
        hi = min(hi, 0.5 * MAX_DELAY_SAMPLES * device.sample_time)
        return np.linspace(0.0, hi, points)
    if free == "sample_time":
        hi = min(SPAN * v, 1.0)
        lo = max(v / SPAN, device.delay / MAX_DELAY_SAMPLES * 2)
        return np.geomspace(lo, hi, points)
    if v <= 0:
        raise InputError("free", f"the device's {free} is 0; give a positive value to scan around, or a range")
    lo, hi = v / SPAN, v * SPAN
    # a device near an input limit (e.g. mass 4e10 kg, limit 1e12): the span ends stop inside the domain, as the
    # widening does (else a point of the scan is a device the model refuses: a 500 found by the fuzzer)
    hi, lo = _inside(device, free, v, hi), _inside(device, free, v, lo)
    return np.geomspace(lo, hi, points)


def _inside(device: Device, free: str, good: float, far: float) -> float:
    """``far``, or the value nearest to it (geometrically) that the device's own domain accepts."""
    def ok(x: float) -> bool:
        try:
            check_device_domain(device_with(device, free, x))
            return True
        except ValueError:          # pydantic's ValidationError and InputError are ValueErrors
            return False
    if ok(far):
        return far
    g, b = math.log(good), math.log(far)
    for _ in range(_LIMIT_BISECTIONS):
        mid = 0.5 * (g + b)
        g, b = (mid, b) if ok(math.exp(mid)) else (g, mid)
    return math.exp(g) * (1.0 - 1e-6) ** (1 if far > good else -1)


def check_range(device: Device, free: str, target: HardwareTarget, lo: float, hi: float) -> None:
    """InputError on range.min / range.max for a requested range that is empty or leaves the input limits."""
    if not lo < hi:
        raise InputError("range.min", f"must be below range.max, got min {lo:g} ≥ max {hi:g}")
    for name, v in (("min", lo), ("max", hi)):
        why = refusal(device, free, v, target)
        if why is not None:
            raise InputError(f"range.{name}", f"{free} = {v:g} is outside the input limits ({why})")


def range_grid(free: str, lo: float, hi: float, points: int) -> np.ndarray:
    """The scan of a requested range: linear for the delay when it starts at 0, else geometric."""
    if lo == 0.0:
        return np.linspace(lo, hi, points)
    return np.geomspace(lo, hi, points)


def widen_end(device: Device, free: str, target: HardwareTarget, end: float, outward: int,
              excess: Callable[[float], float]) -> tuple[np.ndarray, str | None]:
    """New grid points beyond ``end`` (outward +1: up, −1: down), ×_WIDEN at most, and what stopped the
    widening there (None: it may go on).  ``excess`` is the combined excess, used to stop once it no longer
    improves."""
    if end <= 0.0:
        return np.array([]), f"the physical bound {free} = 0"
    far = end * _WIDEN ** outward
    stop = refusal(device, free, far, target)
    if stop is not None:
        good, bad = math.log(end), math.log(far)
        for _ in range(_LIMIT_BISECTIONS):
            mid = 0.5 * (good + bad)
            if refusal(device, free, math.exp(mid), target) is None:
                good = mid
            else:
                bad = mid
        # 1e-6 inside the limit: the forward designs' difference steps (1e-7 relative) stay in the domain
        far = math.exp(good) * (1.0 - 1e-6) ** outward
        stop = f"the input limit {stop}"
        if not (far - end) * outward > 0:
            return np.array([]), stop
    pts = np.geomspace(end, far, _WIDEN_POINTS + 1)[1:]
    if stop is None and not excess(float(pts[-1])) > excess(end):
        stop = f"no improvement: the excess does not grow from {free} = {end:g} to {float(pts[-1]):g}"
    return pts, stop
