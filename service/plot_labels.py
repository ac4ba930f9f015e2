"""The words on a figure: which device it is, its units (translational or rotary) and the swept paths' names.

One place for them, so every plot route says the same thing: a title naming the device (its preset, else its
mass and damping), rigid or cable, with its delay and sample time; stiffness in N/m or N·m/rad.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

from models.device import PRESETS, Device

__all__ = ["Units", "TRANSLATIONAL", "ROTARY", "units", "device_title", "base_device_title", "path_label", "path_scale", "result_label"]


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


def device_title(device: Device) -> str:
    """'lhifam (cable), t_d = 0 ms, T = 1 ms' or 'm = 5.4 kg, b = 3.5 N·s/m (rigid), t_d = 2 ms, T = 1 ms'."""
    u = units(device)
    what = device.preset or f"m = {device.mass:.4g} {u.mass}, b = {device.damping:.4g} {u.damping}"
    kind = "cable" if device.cable else "rigid"
    return f"{what} ({kind}), t_d = {_ms(device.delay)}, T = {_ms(device.sample_time)}"


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


def path_label(path: str, device: Device | Mapping[str, Any] | None = None) -> str:
    """'device.mass' -> 'mass m [kg]'; a path without an entry keeps its name (with no invented unit)."""
    spec = _PATHS.get(path)
    if spec is None:
        return path
    name, sym, kind = spec
    u = units(device)
    unit = {"mass": u.mass, "damping": u.damping, "stiffness": u.stiffness}.get(kind, kind)
    return f"{name} {sym} [{unit}]"


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
    """'critical_stiffness' -> 'critical stiffness $K_{cr}$ [N/m]'; an unknown column keeps its name."""
    spec = _RESULTS.get(column)
    if spec is None:
        return column
    u = units(device)
    unit = {"damping": u.damping, "stiffness": u.stiffness}.get(spec[1], spec[1])
    return f"{spec[0]} [{unit}]"
