"""What binds when the inverse (hardware) design cannot reach its target: measured, not assumed.

When no value of the free parameter in the allowed range meets a target, the free parameter is not (or no
longer) what limits it: at the best value it has reached a bound (a delay of 0, an input limit, the requested
range).  Its own effect is then the wrong name for the limit.  At the best value each other hardware parameter
is moved by a factor 2 in the direction that helps the target (the delay set to 0), and for a force-feedforward
target the filter's band is opened down to half its lowest cutoff; the target's relative excess is re-evaluated
with the full forward design, and the change that raises it most names the limiting effect.  The free parameter
itself is a candidate only when it could still move (a requested range stopped it, not a bound of physics or of
the input limits).
"""

from __future__ import annotations

from models.device import Device
from optim.hardware.hardware_range import refusal
from optim.hardware.hardware_targets import (
    DesignFailed,
    HardwareTarget,
    Probe,
    current_value,
    device_with,
    limiting_effect,
)

__all__ = ["binding_effect"]

_FACTOR = 2.0
_FILTER = ("the force-feedforward filter: its band starts at cutoff_min_hz (the human force bandwidth), and its "
           "phase lag there sets the critical force gain (§5.2, eq. 34)")


def _helping(name: str, param: str) -> list[float]:
    """Factors that help the named target through ``param`` (0: set it to 0)."""
    if param == "delay":
        return [0.0]
    if param == "sample_time":
        return [1 / _FACTOR]
    if param == "mass" and name == "apparent_mass":
        return [1 / _FACTOR]
    if param == "cable.stiffness":      # not monotone (docs/robust.md: K* has a minimum in k_c): both ways
        return [_FACTOR, 1 / _FACTOR]
    return [_FACTOR]


def _label(param: str, factor: float) -> str:
    return f"{param} = 0" if factor == 0 else f"{param} ×{factor:g}" if factor > 1 else f"{param} /{1 / factor:g}"


def binding_effect(device: Device, free: str, target: HardwareTarget, q: float, name: str,
                   free_can_move: bool) -> str:
    """The limiting effect of the named target at the best value q of the free parameter (module docstring)."""
    base = Probe(device, free, target)
    try:
        e0 = base.excess(name, q)
    except DesignFailed:
        return "not measured: the forward design failed at the best value"
    params = ["sample_time", "delay", "damping", "mass"] + (["cable.stiffness"] if device.cable else [])
    tried: list[tuple[float, str, str]] = []
    for param in params:
        if param == free and not free_can_move:
            continue
        value = q if param == free else current_value(device, param)
        for factor in _helping(name, param):
            if factor == 0 and value == 0:
                continue
            moved = value * factor
            if param == free:
                trial, where = device, moved
            else:
                if refusal(device, param, moved, target) is not None:
                    continue
                trial, where = device_with(device, param, moved), q
            if refusal(trial, free, where, target) is not None:
                continue
            try:
                e = Probe(trial, free, target).excess(name, where)
            except DesignFailed:
                continue
            tried.append((e, _label(param, factor), limiting_effect(name, param)))
    if target.feedforward is not None and name != "stiffness":
        lo = target.cutoff_min_hz if target.cutoff_min_hz is not None else target.inertia_requirements().cutoff_min_hz
        wider = target.model_copy(update={"cutoff_min_hz": lo / _FACTOR})
        try:
            tried.append((Probe(device, free, wider).excess(name, q), f"cutoff_min_hz /{_FACTOR:g}", _FILTER))
        except DesignFailed:
            pass
    if not tried:
        return "not measured: no parameter could be moved within the input limits"
    tried.sort(key=lambda t: -t[0])
    e, label, effect = tried[0]
    if not e > e0 + 1e-9 * max(1.0, abs(e0)):
        return (f"none of the hardware parameters helps at {free} = {q:g}: moving each by ×{_FACTOR:g} ("
                + ", ".join(t[1] for t in tried) + f") leaves the relative excess of {name} at ≤ {e0:.4g}")
    rest = ", ".join(f"{t[1]}: {t[0]:+.3g}" for t in tried[1:])
    return (f"{effect} — measured at {free} = {q:g}: {label} moves the relative excess of {name} "
            f"from {e0:+.3g} to {e:+.3g}, the most of the ×{_FACTOR:g} changes ({rest})")
