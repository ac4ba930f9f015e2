"""Schemas of /v1/analysis/stability and /v1/analysis/boundary."""

from __future__ import annotations

from pydantic import BaseModel, Field, model_validator

from optim.domain import check_controller_domain
from optim.stability.boundary import MAX_BOUNDARY_POINTS

from .common import LHIFAM_RIGID, STRICT, Controller, CrossoverOut, Device
from .finite import FiniteModel
from .ladder import GridPoints, GridPointsField, Method
from .verification import VerificationOut, VerifyField


class StabilityRequest(BaseModel):
    model_config = {**STRICT, "json_schema_extra": {"examples": [
        {"device": LHIFAM_RIGID},
        {"device": {"preset": "lhifam", "delay": 0.001}, "controller": {"stiffness": 3500, "damping": 5}},
        {"device": LHIFAM_RIGID, "method": "linear"}]}}
    device: Device
    controller: Controller | None = Field(default=None, description="the wall to check; K_cr is for its B")
    method: Method = Field(default="exact", description="rung of the accuracy ladder")
    grid_points: GridPoints = GridPointsField()
    verify: bool = VerifyField()

    @model_validator(mode="after")
    def _in_domain(self) -> "StabilityRequest":
        """optim.domain: the wall's K and B, made dimensionless by the device (α = K·T²/m, β = B·T/m), within range
        (B may be 0).  A B of 5e-324 used to pass the schema and answer 500 (issue 28)."""
        if self.controller is not None:
            check_controller_domain(self.controller.stiffness, self.device, "stiffness", "controller.stiffness")
            if self.controller.damping != 0.0:
                check_controller_domain(self.controller.damping, self.device, "damping", "controller.damping")
        return self


class StabilityResponse(FiniteModel):
    critical_stiffness: float | None = Field(description="K_cr(B) [N/m]; 0 when no K > 0 is stable; null when every K is")
    crossover_frequency: float | None = Field(description="ω [rad/s] of the crossover that sets K_cr")
    crossovers: list[CrossoverOut] = Field(description="every phase crossover with K > 0")
    gain_margin_db: float | None = Field(description="20·log10(K_cr/K) [dB] when a controller is given")
    stable: bool | None
    passive: bool | None = Field(description="delayed Colgate–Schenkel condition (ARCHITECTURE.md)")
    passivity_required_damping: float | None = Field(description="physical damping passivity needs [N·s/m]")
    passivity_conservative: bool = Field(description="a fractional delay was rounded up for passivity")
    linear_estimate: float = Field(description="(b + B)/(T/2 + t_d) [N/m], eq. 10")
    linear_error: float | None = Field(description="relative error of eq. 10 against this K_cr")
    max_stable_damping: float | None = Field(description="B_max [N·s/m]: no K > 0 is stable above it (computed when B > 0)")
    q_criterion: float | None = Field(description="Q ≈ m_r z_n ω_n [N/m], eq. 22 (cable devices)")
    mode_matters: bool | None = Field(description="cable K_cr differs from the rigid model's by > 5 %")
    rigid_critical_stiffness: float | None = Field(description="K_cr of the rigid model [N/m] (cable devices)")
    damping: float = Field(description="B [N·s/m] analysed")
    method: str
    elapsed_ms: float
    error_estimate: float | None = Field(
        description="relative error bound/estimate of critical_stiffness; null when unbounded (grid rung: no "
                    "crossover on its grid, or its samples show crossovers it missed)")
    error_source: str
    reason: str | None
    verification: VerificationOut | None = Field(None, description="present when verify was true")


class BoundaryRequest(BaseModel):
    model_config = {**STRICT, "json_schema_extra": {"examples": [
        {"device": LHIFAM_RIGID, "points": 40},
        {"device": {"mass": 0.8, "damping": 0.5, "delay": 0.055}, "points": 60}]}}
    device: Device
    damping_max: float | None = Field(default=None, gt=0, le=1e15, description="largest B [N·s/m]; default B_max")
    points: int = Field(default=50, ge=2, le=MAX_BOUNDARY_POINTS)
    verify: bool = VerifyField()


class BoundaryPointOut(BaseModel):
    damping: float = Field(description="B [N·s/m]")
    critical_stiffness: float | None = Field(description="K_cr(B) [N/m]")
    crossover_frequency: float | None = Field(description="ω [rad/s]")
    linear_estimate: float = Field(description="eq. 10 [N/m]")


class BoundaryResponse(FiniteModel):
    points: list[BoundaryPointOut]
    optimum: BoundaryPointOut = Field(description="the B allowing the stiffest stable wall")
    max_stable_damping: float | None = Field(description="B_max [N·s/m]")
    method: str
    elapsed_ms: float
    verification: VerificationOut | None = Field(
        None, description="present when verify was true: every point verified; the optimum's record, the worst verdict")
