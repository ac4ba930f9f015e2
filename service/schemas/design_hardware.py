"""Request and response of POST /v1/design/hardware (and POST /v1/plots/hardware)."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from optim.domain import check_controller_domain

from .common import Device  # the numerics' validated domain (optim.domain) applies

__all__ = ["HardwareTargetIn", "HardwareDesignRequest", "HardwareDesignResponse", "CurvePoint"]

_STRICT = ConfigDict(extra="forbid", allow_inf_nan=False)


class HardwareTargetIn(BaseModel):
    model_config = _STRICT

    stiffness: float = Field(gt=0, le=1e15, description="K the device must render [N/m]")
    min_gain_margin_db: float = Field(6.0, ge=0, le=120, description="gain margin on stiffness [dB]")
    max_damping: float | None = Field(None, gt=0, le=1e12, description="optional cap on the virtual damping B "
                                                                        "[N·s/m]")


class HardwareDesignRequest(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, json_schema_extra={"examples": [
        {"device": {"preset": "lhifam", "cable": None}, "target": {"stiffness": 20000, "min_gain_margin_db": 6},
         "free": "delay"},
        {"device": {"preset": "lhifam"}, "target": {"stiffness": 5000, "max_damping": 20}, "free": "cable.stiffness"},
        {"device": {"mass": 5.4, "damping": 3.5, "delay": 0.001}, "target": {"stiffness": 3000}, "free": "sample_time"},
    ]})

    device: Device
    target: HardwareTargetIn
    free: Literal["sample_time", "delay", "damping", "mass", "cable.stiffness"] = Field(
        description="the hardware parameter to find (the others are the device's)")
    points: int = Field(41, ge=9, le=201, description="points of the trade-off curve")

    @model_validator(mode="after")
    def _in_domain(self) -> "HardwareDesignRequest":
        """optim.domain: the target K and the cap on B, made dimensionless by the device, within range."""
        check_controller_domain(self.target.stiffness, self.device, "stiffness", "target.stiffness")
        if self.target.max_damping is not None:
            check_controller_domain(self.target.max_damping, self.device, "damping", "target.max_damping")
        return self


class CurvePoint(BaseModel):
    value: float = Field(description="the free parameter [SI]")
    achievable_stiffness: float = Field(description="largest K with the margin at this value [N/m] (0: none)")
    damping: float | None = Field(None, description="the B that achieves it [N·s/m]")


class ControllerOut(BaseModel):
    stiffness: float = Field(description="the target K [N/m]")
    damping: float | None = Field(None, description="B of the best controller at the loosest value [N·s/m]")
    achievable_stiffness: float = Field(description="largest K at that value [N/m] (= target at the edge)")
    gain_margin_db: float = Field(description="exact margin of the target K with that B [dB]")


class HardwareDesignResponse(BaseModel):
    status: Literal["optimal", "infeasible", "failed"]
    free: str
    direction: Literal["max", "min"] = Field(description="the direction in which the hardware gets looser")
    value: float | None = Field(None, description="loosest value of the free parameter that renders the target")
    bounded: bool = Field(True, description="false: the target holds to the end of the scanned range")
    controller: ControllerOut | None = None
    intervals: list[tuple[float, float]] = Field(default_factory=list, description="feasible set (intervals)")
    curve: list[CurvePoint] = Field(default_factory=list, description="trade-off curve")
    best_value: float | None = Field(None, description="value of the free parameter with the largest K*")
    best_achievable_stiffness: float | None = Field(None, description="the largest K* on the curve [N/m]")
    matters: bool = Field(True, description="false: K* changes by < 0.1 % over the scanned range")
    reason: str | None = None
    note: str | None = None
    limiting_effect: str | None = None
    elapsed_ms: float
