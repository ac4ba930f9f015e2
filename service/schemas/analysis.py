"""Schemas of /v1/analysis/stability and /v1/analysis/boundary."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, Field, model_serializer, model_validator

from optim.domain import check_controller_domain
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

    @model_validator(mode="after")
    def _in_domain(self) -> "StabilityRequest":
        """optim.domain: the wall's K and B, made dimensionless by the device (α = K·T²/m, β = B·T/m), within range
        (B may be 0).  A B of 5e-324 used to pass the schema and answer 500 (issue 28)."""
        if self.controller is not None:
            if self.controller.stiffness is not None:   # a rendered wall may leave K out (its mass range at K_cr)
                check_controller_domain(self.controller.stiffness, self.device, "stiffness", "controller.stiffness")
            if self.controller.damping != 0.0:
                check_controller_domain(self.controller.damping, self.device, "damping", "controller.damping")
        return self


class LimitCycleOut(FiniteModel):
    exists: bool = Field(description="a stable (attracting) limit cycle is predicted")
    amplitude: float | None = Field(description="[m] amplitude (half peak-to-peak) of x_r of the outermost stable cycle")
    frequency_hz: float | None = Field(description="[Hz] its frequency")
    threshold_amplitude: float | None = Field(
        description="[m] an unstable cycle: motions larger than it grow (a linearly unstable wall held by friction "
                    "or the quantiser's dead band for small motions); null when there is none")
    method: str
    error: str = Field(description="the method's known error (docs/quantisation.md)")


class EnergyAuditOut(FiniteModel):
    net_energy: float = Field(description="[J] the wall's net energy over the push (≤ 0 for a passive display)")
    port_balance_max: float = Field(description="[J] max over time of S(t) − S(0) − user's work (S: the ideal wall's "
                                                "storage)")
    hold_energy: float = Field(description="[J] the wall's energy over the hold's last quarter")
    error_bound: float = Field(description="[J] bound on the rounding error of net_energy")
    active: bool
    mode: Literal["none", "instability", "chatter"]
    hold_motion_counts: float | None = Field(description="peak-to-peak motion over the hold's last quarter [counts]")
    push_force: float = Field(description="[N] the held user force")


class NonlinearVerificationOut(FiniteModel):
    verdict: Literal["confirmed", "contradicted", "not_checkable"]
    reason: str
    chatter_probe: EnergyAuditOut | None = Field(description="a push held halfway between two encoder levels (null: "
                                                         "the simulator refused, see reason)")
    instability_probe: EnergyAuditOut | None = Field(description="a deep push released in two samples")
    measured_state: Literal["settled", "cycle", "growing", "decaying"] | None = Field(
        description="what a release did in simulation (decaying: still dying out at the end: not checkable)")
    measured_amplitude: float | None = Field(description="[m] half peak-to-peak of x_r over the release's last quarter")
    measured_frequency_hz: float | None = Field(description="[Hz] measured cycle frequency")
    predicted_amplitude: float | None = Field(description="[m] the describing function's cycle")
    predicted_frequency_hz: float | None = Field(description="[Hz] the describing function's cycle")
    release_from: float = Field(description="[m] where the simulated release started")


class NonlinearOut(FiniteModel):
    passive_stiffness_limit: float = Field(
        description="[N/m] largest passive K with this encoder and friction: min(2b/T, 2f_c/q) (Abbott & Okamura "
                    "2005) in the theorem's case")
    sampling_term: float = Field(description="[N/m] 2b/T, or zwidth's delayed passivity limit at B when not covered")
    quantization_term: float | None = Field(description="[N/m] 2f_c/q; null (infinite) without an encoder resolution")
    binding: Literal["sampling", "quantization"] = Field(description="the term that sets the limit")
    source: str = Field(description="equation and paper, or the extension used")
    covered: bool = Field(description="true only where the published theorem covers this wall (B = 0, no delay, "
                                      "rigid device); false: an extension without proof")
    limit_cycle: LimitCycleOut
    regime: Literal["passive", "stable_not_passive", "limit_cycle", "unstable", "undetermined"] | None = Field(
        description="passive | stable_not_passive | limit_cycle | unstable | undetermined (the describing function's known error makes the call unsure: the reason says why); null when no stiffness was given")
    reason: str
    verification: NonlinearVerificationOut | None = Field(
        None, description="present when verify was true and a stiffness given: the energy audit and the measured "
                          "cycle by simulation (optim/nonlinear_verification.py)")


class MassRangeOut(FiniteModel):
    min: float | None = Field(description="M [kg] below which the wall goes unstable; null: none")
    max: float | None = Field(description="M [kg] above which the wall goes unstable; null: none")


class StabilityResponse(FiniteModel):
    critical_stiffness: float | None = Field(description="K_cr(B) [N/m]; 0 when K → 0⁺ is unstable (see stable_band); null when every K is")
    crossover_frequency: float | None = Field(description="ω [rad/s] of the crossover that sets K_cr")
    crossovers: list[CrossoverOut] = Field(description="every phase crossover with K > 0")
    gain_margin_db: float | None = Field(description="20·log10(K_cr/K) [dB] when a controller is given")
    stable: bool | None
    passive: bool | None = Field(description="delayed Colgate–Schenkel condition (ARCHITECTURE.md)")
    passivity_required_damping: float | None = Field(
        description="physical damping passivity needs [N·s/m]: with delay, a proven upper bound of the condition's "
                    "sup over θ (at most 1e-13 of its scale K·T/2·(2d+1) + B, plus its rounding bound, above it); "
                    "passive iff b exceeds it")
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
    stable_band: list[float | None] | None = Field(
        None, description="[K_lo, K_hi] [N/m] (K_hi null: unbounded) where critical_stiffness is 0 because B ≥ B_max "
                          "but the closed loop is stable for K_lo < K < K_hi (a band not starting at 0, decided by the "
                          "closed loop); null when no K > 0 is stable there, or K_cr > 0 (stable for 0 < K < K_cr)")
    verification: VerificationOut | None = Field(None, description="present when verify was true")
    nonlinear: NonlinearOut | None = Field(
        None, description="present when the device has encoder_resolution or coulomb_friction (issue 31)")
    mass_range: MassRangeOut | None = Field(
        None, description="the stable virtual masses at (K, B) and this filter; present when the controller names "
                          "mass or velocity_filter and a stiffness (exact rung), null when the wall is unstable")

    @model_serializer(mode="wrap")
    def _omit_absent_blocks(self, handler):   # unannotated: the response schema stays the model's own
        # today's requests answer exactly as before: each block appears only when its input was given
        data = handler(self)
        if data.get("nonlinear", 0) is None:
            del data["nonlinear"]
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
