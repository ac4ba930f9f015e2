"""The words on a figure: which device it is, its units (translational or rotary) and the swept paths' names.

One place for them, so every plot route says the same thing: a title naming the device (its preset, else its
mass and damping), rigid or cable, with its delay and sample time; stiffness in N/m or N·m/rad.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

from models.device import PRESETS, Device

__all__ = ["Units", "TRANSLATIONAL", "ROTARY", "units", "device_title", "base_device_title", "path_label", "path_scale",
           "path_value", "result_label", "problem_label"]


@dataclass(frozen=True)
class Units:
    """The device's units: translational (N/m) or rotary about a joint (N·m/rad)."""
    stiffness: str
    damping: str
    mass: str


TRANSLATIONAL = Units("N/m", "N·s/m", "kg")
ROTARY = Units("N·m/rad", "N·m·s/rad", "kg·m²")


def units(device: Device | Mapping[str, Any] | None) -> Units:
    """The units of a device object, or of a device dict as a request or a study's base gives it."""
    if isinstance(device, Device):
        return ROTARY if device.rotary else TRANSLATIONAL
    preset = device.get("preset") if isinstance(device, Mapping) else None
    return ROTARY if isinstance(preset, str) and Device.preset_is_rotary(preset) else TRANSLATIONAL


def _ms(seconds: float) -> str:
    return f"{seconds * 1e3:.4g} ms"


def _span(lo: float, hi: float, scale: float) -> str:
    return f"{lo * scale:.4g}–{hi * scale:.4g}"


def device_title(device: Device, box: Mapping[str, tuple[float, float]] | None = None, free: str | None = None) -> str:
    """'lhifam (cable), t_d = 0 ms, T = 1 ms' or 'm = 5.4 kg, b = 3.5 N·s/m (rigid), t_d = 2 ms, T = 1 ms'.

    ``box`` (dotted path -> (min, max), SI) is an uncertainty box over the device: a boxed parameter is said as
    its range, never as its nominal value ('t_d = 0.5–1.5 ms'), and the other boxed paths follow after 'box:'.
    ``free`` is a device path left free (a hardware design's axis): said 'free', never as its nominal value."""
    u = units(device)
    box = dict(box or {})

    def said(path: str, value: float, unit: str, scale: float = 1.0) -> str:
        if path == free:
            return "free"
        if path in box:
            return f"= {_span(*box.pop(path), scale)} {unit}"
        return f"= {value * scale:.4g} {unit}"

    what = device.preset or ", ".join(
        f"{sym} {said(f'device.{key}', value, unit)}"
        for key, sym, value, unit in (("mass", "m", device.mass, u.mass), ("damping", "b", device.damping, u.damping)))
    kind = "cable" if device.cable else "rigid"
    timing = ", ".join(f"{sym} {said(f'device.{key}', value, 'ms', 1e3)}"
                       for key, sym, value in (("delay", "t_d", device.delay), ("sample_time", "T", device.sample_time)))
    rest = [f"{_PATHS[p][1] if p in _PATHS else p} = {_span(lo, hi, path_scale(p))} {_path_unit(p, device)}".rstrip()
            for p, (lo, hi) in box.items()]
    if free is not None and not free.startswith(("device.delay", "device.sample_time")) and (
            device.preset or free not in ("device.mass", "device.damping")):
        rest_free = f"; {_PATHS[free][1] if free in _PATHS else free} free"
    else:
        rest_free = ""
    return f"{what} ({kind}), {timing}" + (f"; box: {', '.join(rest)}" if rest else "") + rest_free


def base_device_title(device: Mapping[str, Any], swept: list[str]) -> str:
    """The title of a study's device: its base dict with the swept device fields said to be swept."""
    u = units(device)
    preset = device.get("preset")
    base = dict(PRESETS.get(preset, {})) if isinstance(preset, str) else {}
    base.update(device)
    parts = []
    if isinstance(preset, str):
        parts.append(preset)
    else:
        for key, sym, unit in (("mass", "m", u.mass), ("damping", "b", u.damping)):
            if f"device.{key}" not in swept and isinstance(base.get(key), (int, float)):
                parts.append(f"{sym} = {base[key]:.4g} {unit}")
    kind = "cable" if base.get("cable") or any(p.startswith("device.cable.") for p in swept) else "rigid"
    head = (", ".join(parts) or "device") + f" ({kind})"
    for key, sym in (("delay", "t_d"), ("sample_time", "T")):
        if f"device.{key}" in swept:
            head += f", {sym} swept"
        else:
            value = base.get(key, 0.0 if key == "delay" else 0.001)
            head += f", {sym} = {_ms(value)}" if isinstance(value, (int, float)) else ""
    return head


#: swept path -> (name, symbol, unit kind, scale to the shown unit, shown unit)
_PATHS: dict[str, tuple[str, str, str | None]] = {
    "device.mass": ("mass", "m", "mass"),
    "device.damping": ("damping", "b", "damping"),
    "device.delay": ("delay", "t_d", "ms"),
    "device.sample_time": ("sample time", "T", "ms"),
    "device.cable.stiffness": ("cable stiffness", "k_c", "stiffness"),
    "device.cable.damping": ("cable damping", "b_c", "damping"),
    "device.cable.motor_mass": ("motor mass", "m_r", "mass"),
    "device.cable.body_mass": ("body mass", "m_d", "mass"),
    "device.cable.motor_damping": ("motor damping", "b_r", "damping"),
    "device.cable.body_damping": ("body damping", "b_d", "damping"),
    "device.human.mass": ("hand mass", "m_h", "kg"),
    "device.human.damping": ("hand damping", "b_h", "N·s/m"),
    "device.human.stiffness": ("hand stiffness", "k_h", "N/m"),
    "device.force_sensor.time_constant": ("force-sensor time constant", "T_f", "ms"),
    "requirements.damping": ("virtual damping", "B", "damping"),
    "requirements.stiffness": ("wall stiffness", "K", "stiffness"),
    "requirements.max_damping": ("largest virtual damping", "B_max", "damping"),
    "requirements.min_gain_margin_db": ("required gain margin", "GM", "dB"),
}


def path_scale(path: str) -> float:
    """The factor from the stored SI value to the shown one (seconds are shown in ms)."""
    spec = _PATHS.get(path)
    return 1e3 if spec is not None and spec[2] == "ms" else 1.0


def _path_unit(path: str, device: Device | Mapping[str, Any] | None = None) -> str:
    """The shown unit of a path ('' for a path without an entry)."""
    spec = _PATHS.get(path)
    if spec is None:
        return ""
    u = units(device)
    return {"mass": u.mass, "damping": u.damping, "stiffness": u.stiffness}.get(spec[2], spec[2])


def path_label(path: str, device: Device | Mapping[str, Any] | None = None) -> str:
    """'device.mass' -> 'mass m [kg]'; a path without an entry keeps its name (with no invented unit)."""
    spec = _PATHS.get(path)
    if spec is None:
        return path
    return f"{spec[0]} {spec[1]} [{_path_unit(path, device)}]"


def path_value(path: str, value: float, device: Device | Mapping[str, Any] | None = None) -> str:
    """'device.mass', 2.0 -> 'm = 2 kg' (seconds in ms): a swept value as a legend says it."""
    spec = _PATHS.get(path)
    if spec is None:
        return f"{path} = {value:.4g}"
    return f"{spec[1]} = {value * path_scale(path):.4g} {_path_unit(path, device)}"


#: study result column -> (name, unit kind)
_RESULTS: dict[str, tuple[str, str]] = {
    "critical_stiffness": ("critical stiffness $K_{cr}$", "stiffness"),
    "rigid_critical_stiffness": ("rigid-model $K_{cr}$", "stiffness"),
    "linear_estimate": ("linear estimate (eq. 10)", "stiffness"),
    "stiffness": ("stiffness K", "stiffness"),
    "damping": ("virtual damping B", "damping"),
    "max_stable_damping": ("$B_{max}$", "damping"),
    "crossover_frequency": ("crossover frequency $\\omega_{cr}$", "rad/s"),
    "gain_margin_db": ("gain margin", "dB"),
    "elapsed_ms": ("elapsed", "ms"),
}


def result_label(column: str, device: Device | Mapping[str, Any] | None = None) -> str:
    """'critical_stiffness' -> 'critical stiffness $K_{cr}$ [N/m]'; an unknown column says its name in words
    ('force_gain' -> 'force gain')."""
    spec = _RESULTS.get(column)
    if spec is None:
        return column.replace("_", " ")
    u = units(device)
    unit = {"damping": u.damping, "stiffness": u.stiffness}.get(spec[1], spec[1])
    return f"{spec[0]} [{unit}]"


#: study problem -> what it is in words
_PROBLEMS = {"stability": "wall-stability", "critical_stiffness": "critical-stiffness",
             "stiffness": "stiffest-wall design", "inertia": "lightest-feel design"}


def problem_label(problem: str) -> str:
    """'critical_stiffness' -> 'critical-stiffness': a study's problem as a title says it ('... study 1a2b3c4d')."""
    return _PROBLEMS.get(problem, problem.replace("_", " "))
