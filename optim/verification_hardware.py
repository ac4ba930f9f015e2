"""``verify`` for an inverse (hardware) design: the target controller on the device at the answer's value.

The design says: with the free parameter at ``value``, the target wall K (with its B) keeps the stated margin,
and/or the needed force gain K_f keeps its margin at the chosen cutoff.  Both claims are checked like a
forward design (optim.verification): the critical gain each margin implies, K·10^(GM/20) and
K_f·10^(GM_f/20), on the closed loop just below and above, and the controller itself stable.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace

from models.device import Device
from optim.hardware.hardware_targets import device_with
from optim.transparency.feedforward import resolve_human
from optim.verification import (
    Verdict,
    Verification,
    labelled,
    not_checkable,
    verify_critical_force_gain,
    verify_stiffness_design,
)

__all__ = ["verify_hardware_design"]


def verify_hardware_design(device: Device, free: str, value: float | None, controller: dict | None) -> Verification:
    """The design's controller at its value of the free parameter; not checkable, with the reason, when it delivered
    no value (the target holds over the whole scanned range: unbounded) or no controller."""
    t0 = time.perf_counter()
    if value is None or not controller:
        return not_checkable(t0, "the design states no value of the free parameter (the target holds over the whole "
                                 "scanned range: unbounded)" if value is None else "the design states no controller")
    render = None
    if free == "velocity_filter.cutoff_hz":       # the device is the request's; the wall filters the damper's velocity
        from models.velocity_filter import LowPass

        dev, render = device, (LowPass(kind="low_pass", cutoff_hz=value, order=1), 0.0)
    else:
        dev = device_with(device, free, value)
    parts: list[tuple[str, Verification]] = []
    k, b, gm = controller.get("stiffness"), controller.get("damping"), controller.get("gain_margin_db")
    if k is not None and b is not None and gm is not None and math.isfinite(gm):
        parts.append(("stiffness", verify_stiffness_design(dev, k, b, gm, render=render)))
    kf, cutoff, fgm = controller.get("force_gain"), controller.get("filter_cutoff_hz"), controller.get("force_gain_margin_db")
    if kf and cutoff is not None and fgm is not None and math.isfinite(fgm):
        human, _ = resolve_human(dev)
        parts.append(("force gain", verify_critical_force_gain(dev, human, kf * 10 ** (fgm / 20),
                                                               controller.get("filter_order"), cutoff,
                                                               design_gain=kf)))
    if not parts:
        return not_checkable(t0, "the design states no finite margin to check")
    verdicts = [v.verdict for _, v in parts]
    verdict: Verdict = ("contradicted" if "contradicted" in verdicts else
               "not_checkable" if "not_checkable" in verdicts else "confirmed")
    reasons = [f"{name}: {v.reason}" for name, v in parts if v.reason]
    methods = "; ".join(dict.fromkeys(v.method for _, v in parts if v.method))
    out = replace(parts[0][1], verdict=verdict, method=methods or None, reason="; ".join(reasons) or None,
                  elapsed_ms=(time.perf_counter() - t0) * 1e3)
    return labelled(out, "; ".join(f"{name}: {v.label}" for name, v in parts if v.label) or None)
