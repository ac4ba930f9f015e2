"""Validated device parameters (SI units) and the chapter's presets (Table 2, §4.3, eq. 30-31)."""

from __future__ import annotations

import copy
import math
from decimal import Decimal
from functools import lru_cache
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, model_validator

from models.errors import InputError

__all__ = [
    "Cable",
    "Human",
    "ForceSensor",
    "Device",
    "PRESETS",
    "ROTARY_PRESETS",
    "MAX_DELAY_SAMPLES",
    "delay_limit_rule",
    "preset_names",
    "with_delay",
]

#: Cost limit: the loop delay may be at most this many sample periods.  The exact
#: analysis scans a frequency grid whose size grows linearly with the delay; at
#: this limit one analysis costs well under a second.
MAX_DELAY_SAMPLES = 10_000



def delay_limit_rule(delay: float, sample_time: float) -> str:
    """The delay limit broken by ``delay`` [s], in samples and in the seconds it means at ``sample_time`` [s]."""
    return (f"must satisfy delay/sample_time ≤ {MAX_DELAY_SAMPLES} samples, i.e. delay ≤ "
            f"{MAX_DELAY_SAMPLES * sample_time:g} s at sample_time = {sample_time:g} s; "
            f"{delay:g} s is {delay / sample_time:.6g} samples")


_STRICT = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)
# Bounds that keep every derived dimensionless number representable in double
# precision; no physical device is anywhere near them.
_BIG = 1e12


def _pos(description: str, **kw: Any) -> Any:
    return Field(gt=0, le=_BIG, description=description, **kw)


def _nonneg(description: str, **kw: Any) -> Any:
    return Field(ge=0, le=_BIG, description=description, **kw)


class Cable(BaseModel):
    """Two-mass cable transmission of the chapter's §4 (Fig. 11b, eq. 15-18)."""

    model_config = _STRICT

    motor_mass: float = _pos("m_r, mass pushed by the motor [kg or kg·m²]")
    motor_damping: float = _nonneg("b_r, damping of the motor mass to ground [N·s/m or N·m·s/rad]")
    body_mass: float = _pos("m_d, mass pushed by the user [kg or kg·m²]")
    body_damping: float = _nonneg("b_d, damping of the body mass to ground [N·s/m or N·m·s/rad]")
    stiffness: float = _pos("k_c, cable stiffness [N/m or N·m/rad]")
    damping: float = _nonneg("b_c, cable damping [N·s/m or N·m·s/rad]")

    @property
    def natural_frequency(self) -> float:
        """ω_n of eq. 24 [rad/s]: the first vibration mode of the transmission."""
        m_r, m_d = self.motor_mass, self.body_mass
        return math.sqrt(self.stiffness * (m_r + m_d) / (m_r * m_d))


class Human(BaseModel):
    """The user's grasp Z_h(s) = m_h s² + b_h s + k_h (eq. 30)."""

    model_config = _STRICT

    mass: float = _pos("m_h [kg]")
    damping: float = _nonneg("b_h [N·s/m]")
    stiffness: float = _nonneg("k_h [N/m]")


class ForceSensor(BaseModel):
    """Anti-aliasing filter of the force sensor, G_f(s) = 1/(1 + T_f s) (eq. 31)."""

    model_config = _STRICT

    time_constant: float = _nonneg("T_f [s]; 0 means no filter")


PRESETS: dict[str, dict[str, Any]] = {
    # Chapter Table 2, rotary units about the phi axis (kg·m², N·m·s/rad, N·m/rad).
    "phantom-1.0": {
        "sample_time": 0.001,
        "delay": 0.0,
        "cable": {"motor_mass": 0.895e-3, "motor_damping": 0.0085, "body_mass": 0.155e-3,
                  "body_damping": 0.0, "stiffness": 18.13, "damping": 0.0057},
    },
    # Chapter Table 2 (translational), with the human of eq. 30 and the sensor of eq. 31.
    "lhifam": {
        "sample_time": 0.001,
        "delay": 0.0,
        "cable": {"motor_mass": 0.3, "motor_damping": 0.1, "body_mass": 5.10,
                  "body_damping": 3.4, "stiffness": 79500.0, "damping": 15.0},
        "human": {"mass": 2.0, "damping": 2.0, "stiffness": 10.0},
        "force_sensor": {"time_constant": 0.005},
    },
    # Chapter §4.3 / Fig. 16: the LHifAM after reducing the cable pretension.
    "lhifam-reduced-pretension": {
        "sample_time": 0.001,
        "delay": 0.0,
        "cable": {"motor_mass": 0.3, "motor_damping": 0.1, "body_mass": 5.10,
                  "body_damping": 3.4, "stiffness": 38000.0, "damping": 11.0},
        "human": {"mass": 2.0, "damping": 2.0, "stiffness": 10.0},
        "force_sensor": {"time_constant": 0.005},
    },
}


#: Presets whose axis is a joint: masses in kg·m², damping in N·m·s/rad, stiffness in N·m/rad (Table 2).
ROTARY_PRESETS = frozenset({"phantom-1.0"})


def preset_names() -> list[str]:
    return sorted(PRESETS)


_SCALARS = (str, int, float, bool, type(None))


def _fresh(value: Any) -> Any:
    """A copy of a preset's value that shares nothing mutable with it (dicts copied level by level, scalars kept:
    a study validates one device per point, and deepcopy was most of that)."""
    if type(value) is dict:
        return {k: v if type(v) in _SCALARS else _fresh(v) for k, v in value.items()}
    if type(value) in _SCALARS:
        return value
    return copy.deepcopy(value)


def _merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    out = _fresh(base)
    for key, value in over.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = _merge(out[key], value)
        else:
            out[key] = value
    return out


def _decimal_sum(a: Any, b: Any) -> float:
    """a + b as the user wrote them (0.3 + 5.1 is 5.4, not 5.3999999999999995)."""
    if type(a) is float and type(b) is float and a and b:
        return _nonzero_decimal_sum(a, b)        # a study's points repeat a few masses: ≈ 2 µs each saved
    return float(Decimal(repr(float(a))) + Decimal(repr(float(b))))


@lru_cache(maxsize=4096)
def _nonzero_decimal_sum(a: float, b: float) -> float:
    """_decimal_sum of two nonzero floats (cached by value: no signed zero to tell apart)."""
    return float(Decimal(repr(a)) + Decimal(repr(b)))


def _close(a: float, b: float) -> bool:
    return abs(a - b) <= 1e-9 * max(abs(a), abs(b), 1e-300)


class Device(BaseModel):
    """A haptic device in one axis.

    Rigid model: ``mass`` m and ``damping`` b (eq. 14).  With a ``cable`` block the
    two-mass model of §4 is used and m, b are the sums m_r + m_d, b_r + b_d.
    ``preset`` names one of :data:`PRESETS`; the other fields override it, and an
    explicit ``null`` removes a block of the preset (``"cable": null`` gives the
    rigid model of the same device).
    """

    model_config = _STRICT

    preset: str | None = Field(default=None, description="name of a preset; other fields override it")
    mass: float = _pos("m, total moving mass [kg or kg·m²]")
    damping: float = _nonneg("b, total physical damping [N·s/m or N·m·s/rad]")
    sample_time: float = Field(default=0.001, gt=0, le=1.0, description="T, sample period [s]")
    # The limit is in samples (delay / sample_time ≤ MAX_DELAY_SAMPLES, checked with its unit in _cost_limit); the
    # schema's maximum is what that allows at the largest sample time (1 s), so no request above it is valid.
    delay: float = Field(default=0.0, ge=0, json_schema_extra={"maximum": MAX_DELAY_SAMPLES * 1.0},
                         description=f"t_d, total loop delay [s], any real ≥ 0 with delay/sample_time ≤ "
                                     f"{MAX_DELAY_SAMPLES} samples")
    cable: Cable | None = Field(default=None, description="two-mass cable model (§4)")
    human: Human | None = Field(default=None, description="the user's grasp Z_h (eq. 30)")
    force_sensor: ForceSensor | None = Field(default=None, description="force-sensor filter G_f (eq. 31)")
    encoder_resolution: float | None = Field(
        default=None, gt=0, le=1e3, description="q, encoder resolution on the motor side [m per count, or rad "
        "for a rotary device]; measured position = q·round(x/q). Absent: a continuous encoder")
    coulomb_friction: float | None = Field(
        default=None, ge=0, le=_BIG, description="f_c, Coulomb friction force on the motor-side mass [N, or N·m "
        "for a rotary device]. Absent: no Coulomb friction")
    travel: float | None = Field(default=None, gt=0, le=1e3,
                                 description="range of motion the encoder covers [m, or rad for a rotary device]")

    @model_validator(mode="before")
    @classmethod
    def _apply_preset_and_sums(cls, data: Any) -> Any:
        if not isinstance(data, dict):
            return data
        data = dict(data)
        name = data.get("preset")
        if name is not None:
            if not isinstance(name, str) or name not in PRESETS:
                raise InputError("preset", f"unknown preset {name!r}; known presets: {', '.join(preset_names())}")
            base = PRESETS[name]
            if "cable" in data and data["cable"] is None and "mass" not in data and isinstance(base.get("cable"), dict):
                c = base["cable"]
                data.setdefault("mass", _decimal_sum(c["motor_mass"], c["body_mass"]))
                data.setdefault("damping", _decimal_sum(c["motor_damping"], c["body_damping"]))
            data = _merge(base, data)
        cable = data.get("cable")
        if isinstance(cable, dict):
            try:
                m = _decimal_sum(cable["motor_mass"], cable["body_mass"])
                b = _decimal_sum(cable["motor_damping"], cable["body_damping"])
            except (KeyError, TypeError, ValueError, ArithmeticError):
                return data  # the Cable model reports the missing or bad field
            for key, total, rule in (("mass", m, "motor_mass + body_mass"),
                                     ("damping", b, "motor_damping + body_damping")):
                given = data.get(key)
                if given is None:
                    data[key] = total
                elif isinstance(given, (int, float)) and math.isfinite(given) and math.isfinite(total) \
                        and not _close(float(given), total):
                    raise InputError(key, f"with a cable block, {key} must equal cable {rule} = {total:g}, got {given:g}")
        return data

    @model_validator(mode="after")
    def _encoder_within_travel(self) -> "Device":
        q, travel = self.encoder_resolution, self.travel
        if q is not None and travel is not None and q > travel:
            raise InputError("encoder_resolution", f"{q:g} is larger than the device's travel {travel:g}: "
                             "the encoder would not count once over the range of motion")
        return self

    @model_validator(mode="after")
    def _cost_limit(self) -> "Device":
        if self.delay / self.sample_time > MAX_DELAY_SAMPLES:
            raise InputError("delay", delay_limit_rule(self.delay, self.sample_time))
        return self

    # Dimensionless numbers of Table 1.
    @property
    def delta(self) -> float:
        """δ = bT/m."""
        return self.damping * self.sample_time / self.mass

    @property
    def delay_samples(self) -> float:
        """d = t_d/T."""
        return self.delay / self.sample_time

    @property
    def stiffness_scale(self) -> float:
        """m/T² [N/m]: K = α·m/T² (Table 1)."""
        return self.mass / self.sample_time**2

    @property
    def damping_scale(self) -> float:
        """m/T [N·s/m]: B = β·m/T (Table 1)."""
        return self.mass / self.sample_time

    @property
    def rotary(self) -> bool:
        """True for a rotary preset (its numbers are about a joint: N·m/rad, N·m·s/rad); from the preset, not
        an input: a device without a preset is read as translational."""
        return self.preset_is_rotary(self.preset)

    @staticmethod
    def preset_is_rotary(preset: str | None) -> bool:
        return preset in ROTARY_PRESETS

    @property
    def nonlinear(self) -> bool:
        """True when the device carries an encoder resolution or a Coulomb friction (issue 31)."""
        return self.encoder_resolution is not None or self.coulomb_friction is not None

    @property
    def encoder_counts(self) -> float | None:
        """travel / q: the counts the encoder gives over the device's travel, when both are known."""
        if self.encoder_resolution is None or self.travel is None:
            return None
        return self.travel / self.encoder_resolution

    def rigid(self) -> "Device":
        """The same device without its cable block (m = m_r + m_d, b = b_r + b_d)."""
        return self.model_copy(update={"cable": None})


_set_attr = object.__setattr__


def with_delay(device: Device, delay: float) -> Device:
    """``device.model_copy(update={"delay": delay})`` (its fields, fields set, extra and private state: a shallow
    copy with the delay replaced, nothing validated) without pydantic's generic copy (≈ 7 µs of a study point's
    device, issue 32); tests/optim/studies/test_studies.py holds the two equal.  A model with extra or private
    state takes model_copy itself."""
    if device.__pydantic_extra__ is not None or device.__pydantic_private__ is not None:
        return device.model_copy(update={"delay": delay})
    new = object.__new__(type(device))
    fields = device.__dict__.copy()
    fields["delay"] = delay
    _set_attr(new, "__dict__", fields)
    _set_attr(new, "__pydantic_extra__", None)
    _set_attr(new, "__pydantic_fields_set__", device.__pydantic_fields_set__ | {"delay"})
    _set_attr(new, "__pydantic_private__", None)
    return new
