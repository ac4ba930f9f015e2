"""The targets of the inverse (hardware) design and what a device achieves at one value of its free parameter.

A target is a wall stiffness K_t (the stiffness design of optim.stiffness: the best B, the required gain
margin) and/or a transparency target (the inertia design of optim.transparency.inertia: the largest force-feedforward gain
K_f with the same margin, best over the filter-cutoff band), given either as the force gain K_f,t or as the
apparent mass m_t = m/(1 + K_f) (eq. 28), which needs K_f ≥ m(q)/m_t − 1: a requirement that changes with the
free parameter when that is the mass.

Each target has a relative excess at q, ≥ 0 exactly where it is met:

    stiffness:      K*(q)/K_t − 1
    force_gain:     K_f*(q)/K_f,t − 1
    apparent_mass:  m_t·(1 + K_f*(q))/m(q) − 1   (= m_t/m_app*(q) − 1; met without feedforward when m(q) ≤ m_t)

and the targets hold together where the smallest excess is ≥ 0; the target with the smallest excess limits.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from models.device import Device
from models.filters import MAX_FILTER_ORDER
from optim.errors import InputError
from optim.stiffness import StiffnessDesign, StiffnessRequirements, design_stiffness
from optim.transparency.inertia import InertiaDesign, InertiaRequirements, design_inertia, upper_cutoff_hz

#: Cutoffs of the inertia design's Pareto scan at each value of the free parameter: its band search
#: (optim/transparency/inertia_band.py) doubles them and brackets every jump, so 9 find the same maximum as the
#: default 17 (tests/optim/hardware/test_hardware_feedforward.py checks it against a dense exact scan) at half the cost.
_PARETO_POINTS = 9

__all__ = ["HardwareTarget", "ForceGainAt", "Probe", "DesignFailed", "achievable_stiffness", "achievable_force_gain",
           "device_with", "current_value", "limiting_effect"]


class HardwareTarget(BaseModel):
    """What the device must render: a wall stiffness and/or a force-feedforward gain (or apparent mass), with the
    gain margin of every target.  The one definition of the target's rules: the HTTP request of POST
    /v1/design/hardware uses this model (the service adds JSON-number strictness); the one rule that needs the
    device is :meth:`check`'s."""

    # Lax for internal callers (as models.device.Device); the service validates JSON numbers strictly.
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)

    stiffness: float | None = Field(None, gt=0, le=1e15, description="K the device must render [N/m]; optional "
                                                                     "when force_gain or apparent_mass is given")
    min_gain_margin_db: float = Field(6.0, ge=0, le=120, description="gain margin of every target [dB]: on the "
                                                                     "stiffness and on the force gain")
    max_damping: float | None = Field(None, gt=0, le=1e12, description="optional cap on the virtual damping B "
                                                                        "[N·s/m] (stiffness target)")
    force_gain: float | None = Field(None, gt=0, le=1e9, description="force-feedforward gain K_f to reach "
                                                                     "[dimensionless] (eq. 28)")
    apparent_mass: float | None = Field(None, gt=0, le=1e12, description="apparent mass m/(1 + K_f) to reach [kg], "
                                                                         "below the device's mass; not with "
                                                                         "force_gain")
    cutoff_min_hz: float | None = Field(None, gt=0, le=1e9, description="lowest filter cutoff of the inertia design "
                                                                        "[Hz] (default 10: the human force "
                                                                        "bandwidth)")
    filter_order: int | None = Field(None, ge=1, le=MAX_FILTER_ORDER, description="Butterworth order of the "
                                                                                  "inertia design (default 2)")

    def __init__(self, stiffness: float | None = None, /, **data: Any) -> None:
        """``HardwareTarget(2e5, force_gain=5)``: the stiffness may be given first, by position."""
        if stiffness is not None:
            data["stiffness"] = stiffness
        super().__init__(**data)

    @model_validator(mode="after")
    def _consistent(self) -> "HardwareTarget":
        if self.force_gain is not None and self.apparent_mass is not None:
            raise InputError("apparent_mass", "give force_gain or apparent_mass, not both (K_f = m/m_app − 1)")
        if self.stiffness is None and self.feedforward is None:
            raise InputError("stiffness", "give at least one target: stiffness, force_gain or apparent_mass")
        if self.max_damping is not None and self.stiffness is None:
            raise InputError("max_damping", "caps the B of the stiffness target; give target.stiffness")
        for name in ("cutoff_min_hz", "filter_order"):
            if getattr(self, name) is not None and self.feedforward is None:
                raise InputError(name, "applies to the force-feedforward design; give target.force_gain "
                                 "or target.apparent_mass")
        return self

    @property
    def feedforward(self) -> str | None:
        """"force_gain" | "apparent_mass" | None: which transparency target is given."""
        if self.force_gain is not None:
            return "force_gain"
        return "apparent_mass" if self.apparent_mass is not None else None

    @property
    def names(self) -> tuple[str, ...]:
        """The targets given, stiffness first."""
        return tuple(n for n in ("stiffness", "force_gain", "apparent_mass") if getattr(self, n) is not None)

    def requirements(self) -> StiffnessRequirements:
        return StiffnessRequirements(min_gain_margin_db=self.min_gain_margin_db, max_damping=self.max_damping)

    def inertia_requirements(self) -> InertiaRequirements:
        given = {k: v for k, v in (("cutoff_min_hz", self.cutoff_min_hz), ("filter_order", self.filter_order))
                 if v is not None}
        return InertiaRequirements(min_gain_margin_db=self.min_gain_margin_db, pareto_points=_PARETO_POINTS, **given)

    def required_force_gain(self, mass: float) -> float:
        """K_f the transparency target needs on a device of this mass [dimensionless]; ≤ 0: met without it."""
        if self.force_gain is not None:
            return self.force_gain
        return mass / self.apparent_mass - 1.0

    def check(self, device: Device, free: str) -> None:
        """InputError("target.apparent_mass", rule) for a target this device cannot serve (the target's own rules
        hold by construction)."""
        # With the mass free the device's own mass is only the centre of the scan: any m_t can bind somewhere.
        if self.apparent_mass is not None and free != "mass" and not self.apparent_mass < device.mass:
            raise InputError("target.apparent_mass", f"must be below the device's mass {device.mass:g} kg "
                             f"(force feedforward only lowers the apparent mass m/(1 + K_f))")


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


def current_value(device: Device, free: str) -> float:
    """The device's own value of the free parameter [SI]."""
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


@dataclass(frozen=True)
class ForceGainAt:
    """The largest force-feedforward gain with the required margin at one value of the free parameter."""

    status: Literal["optimal", "failed"]
    """failed: the inertia design did not converge."""
    force_gain: float
    """K_f* [dimensionless]: the inertia design's best over its cutoff band; 0 when the band is empty (no
    admissible filter: no feedforward), inf when the model bounds no K_f at some cutoff."""
    filter_cutoff_hz: float | None
    """the cutoff where K_f* is reached [Hz]."""
    critical_force_gain: float | None
    """exact K_f,cr at that cutoff [dimensionless]."""
    mass: float
    """m of the device at this value [kg]."""
    design: InertiaDesign | None = None
    reason: str | None = None

    @property
    def apparent_mass(self) -> float:
        """m/(1 + K_f*) [kg] (eq. 28)."""
        return self.mass / (1.0 + self.force_gain)


def achievable_force_gain(device: Device, free: str, value: float, target: HardwareTarget) -> ForceGainAt:
    """K_f* of the device with the free parameter at ``value`` (optim.transparency.inertia.design_inertia, min_apparent_mass)."""
    dev = device_with(device, free, value)
    req = target.inertia_requirements()
    hi, src = upper_cutoff_hz(dev)
    if not req.cutoff_min_hz < hi:
        # The filter must pass the human force bandwidth and stop below the first mode / 0.4 × Nyquist:
        # no cutoff does both here, so no force feedforward is admissible.
        return ForceGainAt("optimal", 0.0, None, None, dev.mass, reason=(
            f"no filter cutoff in [{req.cutoff_min_hz:g}, {hi:g}] Hz (upper end: {src}): no force feedforward"))
    d = design_inertia(dev, req)
    if d.status == "optimal":
        return ForceGainAt("optimal", float(d.force_gain), float(d.filter_cutoff_hz), float(d.critical_force_gain),
                           dev.mass, d)
    if d.status == "infeasible" and any(not math.isfinite(p.critical_force_gain) for p in d.pareto):
        at = next(p for p in d.pareto if not math.isfinite(p.critical_force_gain))
        return ForceGainAt("optimal", math.inf, float(at.filter_cutoff_hz), math.inf, dev.mass, d, d.reason)
    return ForceGainAt("failed", 0.0, None, None, dev.mass, d, d.reason or f"inertia design {d.status}")


class DesignFailed(Exception):
    """A forward design at one value of the free parameter did not converge (the message says which, where)."""


class Probe:
    """The forward designs a target needs, at values of the free parameter, memoised per design: a Brent
    search on one target's excess runs only that target's design."""

    def __init__(self, device: Device, free: str, target: HardwareTarget):
        self.device, self.free, self.target = device, free, target
        self._stiffness: dict[float, tuple] = {}
        self._force: dict[float, ForceGainAt] = {}

    def stiffness(self, q: float) -> tuple[float, float | None, StiffnessDesign]:
        """achievable_stiffness at q; DesignFailed when the stiffness design failed."""
        q = float(q)
        if q not in self._stiffness:
            self._stiffness[q] = achievable_stiffness(self.device, self.free, q, self.target)
        k, b, d = self._stiffness[q]
        if d.status == "failed":
            raise DesignFailed(f"the stiffness design failed at {self.free} = {q:g}: {d.reason}")
        return k, b, d

    def force(self, q: float) -> ForceGainAt:
        """achievable_force_gain at q; DesignFailed when the inertia design failed."""
        q = float(q)
        if q not in self._force:
            self._force[q] = achievable_force_gain(self.device, self.free, q, self.target)
        f = self._force[q]
        if f.status == "failed":
            raise DesignFailed(f"the inertia design failed at {self.free} = {q:g}: {f.reason}")
        return f

    def excess(self, name: str, q: float) -> float:
        """The named target's relative excess at q (module docstring): ≥ 0 exactly where it is met."""
        t = self.target
        if name == "stiffness":
            return self.stiffness(q)[0] / t.stiffness - 1.0
        f = self.force(q)
        if name == "force_gain":
            return f.force_gain / t.force_gain - 1.0
        return t.apparent_mass * (1.0 + f.force_gain) / f.mass - 1.0

    def curve_entry(self, q: float) -> dict:
        k, b = self.stiffness(q)[:2] if self.target.stiffness is not None else (None, None)
        f = self.force(q) if self.target.feedforward is not None else None
        return {"value": float(q), "achievable_stiffness": k, "damping": b,
                "achievable_force_gain": f.force_gain if f else None,
                "filter_cutoff_hz": f.filter_cutoff_hz if f else None,
                "apparent_mass": f.apparent_mass if f else None}


_EFFECTS = {
    "stiffness": {
        "sample_time": "sampling: the zero-order hold's half-sample lag (eq. 10: K < (b+B)/(T/2 + t_d))",
        "delay": "loop delay: its phase lag (eq. 10: K < (b+B)/(T/2 + t_d))",
        "damping": "physical damping: the dissipation that pays for the sampled loop's energy leak (eq. 10)",
        "mass": "mass: with less inertia the virtual damper destabilises sooner (Table 1: β = BT/m, α = KT²/m)",
        "cable.stiffness": "the cable's vibration mode: its resonance moves toward the crossover (§4, eq. 22-24)",
    },
    "force_gain": {
        "sample_time": "sampling: the hold's lag lowers the critical force gain K_f,cr, and the filter band "
                       "(up to 0.4 × Nyquist) shrinks (§5.1-5.2, eq. 29-34)",
        "delay": "loop delay: the phase crossover of K_f·D·G_1 moves to lower frequencies, towards the worst case "
                 "K_f,cr ≈ 1 + m/m_h (§5.1, eq. 33)",
        "damping": "physical damping: less dissipation lowers the critical force gain K_f,cr (§5.1)",
        "mass": "mass: a lighter device against the same hand allows less force gain (worst case "
                "K_f,cr ≈ 1 + m/m_h, eq. 33)",
        "cable.stiffness": "the cable's vibration mode: a softer cable lowers the critical force gain and the first "
                           "mode, the top of the filter band (§5.2, eq. 24, 34)",
    },
}
_EFFECTS["apparent_mass"] = dict(_EFFECTS["force_gain"], mass=(
    "mass: the apparent mass m/(1 + K_f) grows with the device's mass, since K_f,cr grows no faster than "
    "1 + m/m_h (eq. 28, 33): a heavier device feels heavier"))


def limiting_effect(target_name: str, free: str) -> str:
    """The physical effect through which ``free`` limits the named target."""
    return _EFFECTS[target_name][free]
