"""Schemas of /v1/analysis/stability and /v1/analysis/boundary."""

from __future__ import annotations

from pydantic import BaseModel, Field, model_serializer

from optim.stability.boundary import MAX_BOUNDARY_POINTS

from .common import LHIFAM_RIGID, STRICT, CrossoverOut, Device, RenderedController, RenderedEnvironment
from .finite import FiniteModel
from .ladder import GridPoints, GridPointsField, Method
from .verification import VerificationOut, VerifyField


class StabilityRequest(BaseModel):
    model_config = {**STRICT, "json_schema_extra": {"examples": [
        {"device": LHIFAM_RIGID},
        {"device": {"preset": "lhifam", "delay": 0.001}, "controller": {"stiffness": 3500, "damping": 5}},
        {"device": LHIFAM_RIGID, "method": "linear"}]}}
    device: Device
    controller: RenderedController | None = Field(
        default=None, description="the wall to check; K_cr is for its B, virtual mass and velocity filter")
    method: Method = Field(default="exact", description="rung of the accuracy ladder")
    grid_points: GridPoints = GridPointsField()
    verify: bool = VerifyField()


class MassRangeOut(FiniteModel):
    min: float | None = Field(description="M [kg] below which the wall goes unstable; null: none")
    max: float | None = Field(description="M [kg] above which the wall goes unstable; null: none")


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
    mass_range: MassRangeOut | None = Field(
        None, description="the stable virtual masses at (K, B) and this filter; present when the controller names "
                          "mass or velocity_filter and a stiffness (exact rung), null when the wall is unstable")

    @model_serializer(mode="wrap")
    def _omit_absent_mass_range(self, handler):   # unannotated: the response schema stays the model's own
        # today's requests answer exactly as before: the block appears only when the rendering was asked for
        data = handler(self)
        if data.get("mass_range") is None and "mass_range" not in self.model_fields_set:
            data.pop("mass_range", None)
        return data


class BoundaryRequest(BaseModel):
    model_config = {**STRICT, "json_schema_extra": {"examples": [
        {"device": LHIFAM_RIGID, "points": 40},
        {"device": {"mass": 0.8, "damping": 0.5, "delay": 0.055}, "points": 60}]}}
    device: Device
    damping_max: float | None = Field(default=None, gt=0, le=1e15, description="largest B [N·s/m]; default B_max")
    points: int = Field(default=50, ge=2, le=MAX_BOUNDARY_POINTS)
    controller: RenderedEnvironment | None = Field(
        default=None, description="virtual mass and velocity filter of the walls on the boundary (default: today's)")
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
