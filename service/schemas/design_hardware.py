"""Request and response of POST /v1/design/hardware (and POST /v1/plots/hardware)."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_serializer, model_validator

from optim.domain import check_controller_domain, check_cutoff_domain
from optim.hardware.hardware_cutoff import check_cutoff_range
from optim.hardware.hardware_range import check_range
from optim.hardware.hardware_targets import HardwareTarget
from optim.hardware.quantisation import QUANTISATION_FREE, check_quantisation_request

from .common import Device  # the numerics' validated domain (optim.domain) applies
from .finite import FiniteModel
from .verification import VerificationOut, VerifyField

__all__ = ["HardwareTargetIn", "ValueRangeIn", "HardwareDesignRequest", "HardwareDesignResponse", "CurvePoint", "EdgeOut",
           "ControllerOut"]

_STRICT = ConfigDict(extra="forbid", allow_inf_nan=False, strict=True)


class HardwareTargetIn(HardwareTarget):
    # The fields, bounds, cross-field rules and their messages are optim's (one source); the request adds
    # JSON-number strictness.
    model_config = _STRICT

    def core(self) -> HardwareTarget:
        """The numerics' target."""
        return HardwareTarget(**self.model_dump())


class ValueRangeIn(BaseModel):
    model_config = _STRICT

    min: float = Field(ge=0, description="lowest value of the free parameter to scan [SI]")
    max: float = Field(gt=0, description="highest value [SI]; above min, both within the input limits "
                                         "(docs/limits.md)")


class HardwareDesignRequest(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, strict=True, json_schema_extra={"examples": [
        {"device": {"preset": "lhifam", "cable": None}, "target": {"stiffness": 20000, "min_gain_margin_db": 6},
         "free": "delay"},
        {"device": {"preset": "lhifam"}, "target": {"stiffness": 5000, "max_damping": 20}, "free": "cable.stiffness"},
        {"device": {"mass": 5.4, "damping": 3.5, "delay": 0.001}, "target": {"stiffness": 3000}, "free": "sample_time"},
        {"device": {"preset": "lhifam", "cable": None}, "target": {"stiffness": 2e5, "force_gain": 5}, "free": "delay"},
        {"device": {"preset": "lhifam", "cable": None}, "target": {"apparent_mass": 0.5}, "free": "mass"},
    ]})

    device: Device
    target: HardwareTargetIn
    free: Literal["sample_time", "delay", "damping", "mass", "cable.stiffness", "encoder_resolution",
                  "coulomb_friction", "velocity_filter.cutoff_hz"] = Field(
        description="the hardware parameter to find (the others are the device's); encoder_resolution (the "
                    "coarsest q) and coulomb_friction (the least f_c) keep target.stiffness passive as a virtual "
                    "spring (optim/hardware/quantisation.py); velocity_filter.cutoff_hz: the lowest cutoff of a "
                    "first-order low-pass on the damper's velocity that renders a stiffness target")
    points: int = Field(41, ge=9, le=201, description="points of the trade-off curve")
    range: ValueRangeIn | None = Field(None, description="scan exactly this range of the free parameter [SI]; by "
                                                         "default value/30 … value·30 (delay 0 … 30 samples), "
                                                         "widened while the target is out of reach (docs/robust.md)")
    verify: bool = VerifyField()

    @model_validator(mode="after")
    def _in_domain(self) -> "HardwareDesignRequest":
        """The target's rules (optim.hardware.hardware_targets) and optim.domain: the target K, the cap on B and the lowest
        cutoff, made dimensionless by the device, within range."""
        t = self.target    # its own rules held when it was validated (optim's model); this one needs the device
        if self.free in QUANTISATION_FREE:
            check_quantisation_request(t.core(), self.range is not None)
        t.check(self.device, self.free)
        if t.stiffness is not None:
            check_controller_domain(t.stiffness, self.device, "stiffness", "target.stiffness")
        if t.max_damping is not None:
            check_controller_domain(t.max_damping, self.device, "damping", "target.max_damping")
        if t.cutoff_min_hz is not None:
            check_cutoff_domain(t.cutoff_min_hz, self.device.sample_time, "target.cutoff_min_hz")
        if self.range is not None and self.free == "velocity_filter.cutoff_hz":
            check_cutoff_range(self.device, self.range.min, self.range.max)
        elif self.range is not None:     # optim's rule (empty range, input limits at both ends): one source
            check_range(self.device, self.free, t.core(), self.range.min, self.range.max)
        return self


class CurvePoint(BaseModel):
    value: float = Field(description="the free parameter [SI]")
    achievable_stiffness: float | None = Field(None, description="largest K with the margin at this value [N/m] "
                                                                 "(0: none; null without a stiffness target)")
    damping: float | None = Field(None, description="the B that achieves it [N·s/m]")
    achievable_force_gain: float | None = Field(None, description="largest K_f with the margin, best over the "
                                                                  "cutoff band (null without a force-feedforward "
                                                                  "target, or when the model bounds none)")
    filter_cutoff_hz: float | None = Field(None, description="the cutoff where it is reached [Hz] (null: no "
                                                             "cutoff in the band)")
    apparent_mass: float | None = Field(None, description="m/(1 + achievable K_f) at this value [kg]")


class EdgeOut(BaseModel):
    value: float = Field(description="an edge of the feasible set [SI]")
    limiting_target: Literal["stiffness", "force_gain", "apparent_mass"] = Field(
        description="the target that binds there")


class ControllerOut(BaseModel):
    stiffness: float | None = Field(None, description="the target K [N/m]")
    damping: float | None = Field(None, description="B of the best controller at the loosest value [N·s/m]")
    achievable_stiffness: float | None = Field(None, description="largest K at that value [N/m] (= target at the "
                                                                 "edge when the stiffness limits)")
    gain_margin_db: float | None = Field(None, description="exact margin of the target K with that B [dB]")
    force_gain: float | None = Field(None, description="the K_f the target needs at that value (m/m_app − 1 for "
                                                       "an apparent-mass target, 0 when not needed)")
    filter_cutoff_hz: float | None = Field(None, description="cutoff with the largest critical force gain [Hz]")
    filter_order: int | None = None
    achievable_force_gain: float | None = Field(None, description="largest K_f at that value (= the needed K_f "
                                                                  "at the edge when it limits)")
    apparent_mass: float | None = Field(None, description="m/(1 + force_gain) [kg]")
    critical_force_gain: float | None = Field(None, description="exact K_f,cr at that cutoff")
    force_gain_margin_db: float | None = Field(None, description="20·log10(K_f,cr/force_gain) [dB]")


class HardwareDesignResponse(FiniteModel):
    status: Literal["optimal", "infeasible", "failed"]
    free: str
    direction: Literal["max", "min"] = Field(description="the direction in which the hardware gets looser")
    value: float | None = Field(None, description="loosest value of the free parameter that renders the target")
    bounded: bool = Field(True, description="false: the target holds to the end of the scanned range")
    controller: ControllerOut | None = None
    intervals: list[tuple[float, float]] = Field(default_factory=list, description="feasible set (intervals)")
    edges: list[EdgeOut] = Field(default_factory=list, description="edges of the feasible set and the target "
                                                                   "binding at each")
    curve: list[CurvePoint] = Field(default_factory=list, description="trade-off curve")
    best_value: float | None = Field(None, description="value of the free parameter where the targets are "
                                                       "best met (largest smallest relative excess)")
    best_achievable_stiffness: float | None = Field(None, description="K* at best_value [N/m]")
    best_achievable_force_gain: float | None = Field(None, description="K_f* at best_value")
    best_apparent_mass: float | None = Field(None, description="m/(1 + K_f*) at best_value [kg]")
    matters: bool = Field(True, description="false: no achievable value changes by > 0.1 % over the scanned range")
    limiting_target: Literal["stiffness", "force_gain", "apparent_mass"] | None = Field(
        None, description="the target that sets the answer (infeasible: the one furthest from reach at best_value)")
    reason: str | None = None
    note: str | None = None
    limiting_effect: str | None = Field(None, description="the physical effect that sets the answer; infeasible: "
                                                          "measured at best_value (which ×2 change of another "
                                                          "parameter helps most)")
    scanned_range: tuple[float, float] | None = Field(None, description="the range of the free parameter scanned")
    range_source: str | None = Field(None, description="request, the default span, or how it was widened and "
                                                       "what stopped it (a physical bound, an input limit, no "
                                                       "improvement)")
    elapsed_ms: float
    verification: VerificationOut | None = Field(None, description="present when verify was true: the target "
                                                                   "controller checked at the answer's value")
    quantisation: dict | None = Field(None, description="free = encoder_resolution | coulomb_friction: the passive "
                                                        "limit's terms, the counts over device.travel, and the "
                                                        "nonlinear analysis at the answer and 1 % looser "
                                                        "(optim/hardware/quantisation.py)")

    @model_serializer(mode="wrap")
    def _omit_absent_quantisation(self, handler):   # unannotated: the response schema stays the model's own
        # today's hardware designs answer exactly as before: the block appears only for free = encoder/friction
        data = handler(self)
        if data.get("quantisation", 0) is None:
            del data["quantisation"]
        return data
