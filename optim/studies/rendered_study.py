"""The rendered wall in the ``stability`` and ``critical_stiffness`` studies (issue 30): a point whose requirements
carry a ``controller`` ({mass?, velocity_filter?}, swept as ``controller.mass``,
``controller.velocity_filter.cutoff_hz`` …) is analysed by optim.stability.analysis.analyse_stability on the exact
rung with that rendering, one point at a time (the batched scan is written for today's wall); the others keep the
batch path, bit for bit.

A rendered point's row has the problem's columns (the same names, from the same analysis fields) plus
``mass_range.min`` and ``mass_range.max`` [kg] (the stable virtual masses at (K, B); None without a stiffness or
for an unstable wall).
"""

from __future__ import annotations

import math
from typing import Any, Callable, Mapping, Sequence

from pydantic import TypeAdapter, ValidationError

from models.device import Device
from models.velocity_filter import MAX_VIRTUAL_MASS, VelocityFilter, rendering
from optim.errors import InputError
from optim.stability.analysis import analyse_stability

__all__ = ["CONTROLLER_PATHS", "RENDERED_PROBLEMS", "check_controller", "controller_rendering", "split_rendered"]

#: the controller's numbers a study may sweep, and their kind
CONTROLLER_PATHS = {"controller.mass": "float", "controller.velocity_filter.cutoff_hz": "float",
                    "controller.velocity_filter.order": "int", "controller.velocity_filter.samples": "int"}
#: the problems that take ``base.controller``
RENDERED_PROBLEMS = ("stability", "critical_stiffness")
_FILTER = TypeAdapter(VelocityFilter)
Row = tuple[dict | None, str | None]


def check_controller(controller: Any) -> None:
    """InputError naming ``controller.…`` unless ``controller`` is {mass?, velocity_filter?} with a finite mass and a
    valid filter (what needs the sample time, a cutoff below Nyquist, is checked per point)."""
    if not isinstance(controller, Mapping):
        raise InputError("controller", "must be an object {mass?, velocity_filter?}")
    for key in controller:
        if key in ("stiffness", "damping"):
            raise InputError(f"controller.{key}", f"a study's wall {key} is requirements.{key}")
        if key not in ("mass", "velocity_filter"):
            raise InputError(f"controller.{key}", "unknown field (a study's controller has mass, velocity_filter)")
    mass = controller.get("mass")
    if mass is not None and (isinstance(mass, bool) or not isinstance(mass, (int, float)) or not math.isfinite(mass)
                             or abs(mass) > MAX_VIRTUAL_MASS):
        raise InputError("controller.mass", f"must be a finite number with |M| ≤ {MAX_VIRTUAL_MASS:g} [kg]")
    spec = controller.get("velocity_filter")
    if spec is not None:
        try:
            _FILTER.validate_python(spec)
        except ValidationError as exc:
            e = exc.errors()[0]
            loc = ".".join(str(x) for x in e.get("loc", ()) if str(x) not in ("backward_difference", "low_pass",
                                                                               "moving_average", "transfer_function"))
            raise InputError("controller.velocity_filter" + (f".{loc}" if loc else ""), e["msg"]) from None


def controller_rendering(controller: Mapping[str, Any], device: Device):
    """The Rendering of a checked ``controller`` at the device's sample time (InputError naming
    ``controller.velocity_filter.…`` for a cutoff at or above Nyquist)."""
    spec = controller.get("velocity_filter")
    try:
        return rendering(None if spec is None else _FILTER.validate_python(spec), float(controller.get("mass") or 0.0),
                         device.sample_time)
    except InputError as exc:
        raise InputError(f"controller.{exc.field}", exc.rule) from None


def _finite(x: float | None) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


_CRITICAL_KEYS = ("critical_stiffness", "crossover_frequency", "max_stable_damping", "linear_estimate")
_STABILITY_KEYS = ("critical_stiffness", "crossover_frequency", "damping", "stiffness", "gain_margin_db", "stable",
                   "passive", "passivity_required_damping", "passivity_conservative", "linear_estimate",
                   "linear_error", "max_stable_damping", "q_criterion", "mode_matters", "rigid_critical_stiffness",
                   "error_estimate")


def rendered_row(problem: str, device: Device, req: Mapping[str, Any]) -> Row:
    """One rendered point's row, or its failure's reason."""
    try:
        r = controller_rendering(req["controller"], device)
        k = req.get("stiffness")
        res = analyse_stability(device, None if k is None else float(k), float(req.get("damping") or 0.0), "exact",
                                rendering=r)
    except InputError as exc:
        return None, f"{exc.field}: {exc.rule}"
    if problem == "critical_stiffness":
        out: dict[str, Any] = {key: _finite(getattr(res, key)) for key in _CRITICAL_KEYS}
        if k is not None:
            out["stable"] = res.stable
            out["gain_margin_db"] = _finite(res.gain_margin_db)
    else:
        out = {}
        for key in _STABILITY_KEYS:
            v = getattr(res, key)
            out[key] = _finite(v) if isinstance(v, float) else v
    out["reason"] = res.reason
    out["mass_range.min"] = None if res.mass_range is None else _finite(res.mass_range.min)
    out["mass_range.max"] = None if res.mass_range is None else _finite(res.mass_range.max)
    return out, None


def split_rendered(problem: str, devices: Sequence[Device], requirements: Sequence[Mapping[str, Any]],
                   batch: Callable[[Sequence[Device], Sequence[Mapping[str, Any]]], list[Row]]) -> list[Row]:
    """``batch`` on the points without a controller, ``rendered_row`` on the others, in order."""
    rendered = [i for i, r in enumerate(requirements) if r.get("controller") is not None]
    if not rendered:
        return batch(devices, requirements)
    plain = [i for i in range(len(devices)) if requirements[i].get("controller") is None]
    out: list[Row] = [(None, None)] * len(devices)
    for i, row in zip(plain, batch([devices[i] for i in plain], [requirements[i] for i in plain]) if plain else []):
        out[i] = row
    for i in rendered:
        out[i] = rendered_row(problem, devices[i], requirements[i])
    return out
