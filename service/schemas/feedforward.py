"""Schemas of /v1/analysis/force-feedforward and /v1/design/inertia (chapter §5)."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, Field, WrapValidator, model_validator

from models.filters import MAX_FILTER_ORDER
from optim.domain import check_cutoff_domain, check_human_domain, check_human_mass
from optim.transparency.inertia_requirements import InertiaRequirements

from .common import STRICT, Device, json_numbers
from .design_stiffness import RangeIn
from .finite import FiniteModel
from .ladder import DesignStatus, DesignStatusField, ExactCheckOut, GridPoints, GridPointsField, Method, MethodField
from .verification import VerificationOut, VerifyField

_LHIFAM_FF = {"mass": 5.4, "damping": 3.5, "sample_time": 0.001,
              "human": {"mass": 2, "damping": 2, "stiffness": 10}, "force_sensor": {"time_constant": 0.005}}


class FilterIn(BaseModel):
    model_config = STRICT
    cutoff_hz: float = Field(gt=0, le=1e9, description="f_c [Hz], below the Nyquist frequency 1/(2T)")
    order: int = Field(default=2, ge=1, le=MAX_FILTER_ORDER, description="Butterworth order")


class ForceFeedforwardRequest(BaseModel):
    model_config = {**STRICT, "json_schema_extra": {"examples": [
        {"device": _LHIFAM_FF},
        {"device": {"preset": "lhifam"}, "filter": {"cutoff_hz": 30, "order": 2}}]}}
    device: Device = Field(description="needs a human block (else the chapter's eq. 30 grasp is used, and said)")
    filter: FilterIn | None = Field(default=None, description="Butterworth D(z), prewarped bilinear; none by default")
    method: Method = Field(
        default="exact", description="rung of the accuracy ladder: linear = eq. 33 (1 + m/m_h, large delays), "
                                     "grid = fixed log grid, exact, reference = 40-digit mpmath (slow)")
    grid_points: GridPoints = GridPointsField()
    verify: bool = VerifyField()

    @model_validator(mode="after")
    def _in_domain(self) -> "ForceFeedforwardRequest":
        if self.filter is not None:  # optim.domain: f_c·T within the validated range
            check_cutoff_domain(self.filter.cutoff_hz, self.device.sample_time, "filter.cutoff_hz")
        return self


class ForceCrossoverOut(BaseModel):
    frequency: float = Field(description="ω [rad/s]")
    force_gain: float = Field(description="K_f putting a closed-loop pole at e^{jωT}")


class HumanOut(BaseModel):
    mass: float = Field(description="m_h [kg]")
    damping: float = Field(description="b_h [N·s/m]")
    stiffness: float = Field(description="k_h [N/m]")


class ForceFeedforwardResponse(FiniteModel):
    critical_force_gain: float | None = Field(description="K_f,cr (eq. 32/34); null when no K_f > 0 is unstable")
    crossover_frequency: float | None = Field(description="ω [rad/s] of the crossover setting K_f,cr; π/T is Nyquist")
    crossovers: list[ForceCrossoverOut] = Field(description="every phase crossover with K_f > 0")
    worst_case_force_gain: float = Field(description="1 + m/m_h, eq. 33")
    apparent_mass_at_critical: float | None = Field(description="m/(1 + K_f,cr) [kg], the limit, not a design")
    model: Literal["rigid", "cable"]
    rigid_critical_force_gain: float | None = Field(description="what the rigid model claims (cable devices)")
    rigid_optimistic: bool | None = Field(description="the rigid model's K_f,cr exceeds the cable model's by > 20 %")
    human: HumanOut
    human_source: str = Field(description="request device, or the chapter's eq. 30 grasp when absent")
    force_sensor_time_constant: float = Field(description="T_f [s] used (0: no sensor filter)")
    method: str
    elapsed_ms: float
    error_estimate: float | None = Field(default=None, description="relative error bound/estimate of "
                                         "critical_force_gain (null when not finite)")
    error_source: str | None = None
    reason: str | None
    notes: list[str]
    verification: VerificationOut | None = Field(None, description="present when verify was true")


class InertiaRequirementsIn(InertiaRequirements):
    # The fields, bounds, cross-field rules and their messages are optim's (one source); the request adds
    # JSON-number strictness (the nested grasps and mass range too: InertiaRequirementsField) and the robust box.
    model_config = STRICT

    uncertainty: dict[str, RangeIn] | None = Field(
        default=None, description="robust design: dotted device paths (device.mass, device.delay, "
                                  "device.cable.stiffness, device.human.mass, …) mapped to {min, max}; K_f and the "
                                  "cutoff then hold for every device of the box (not device.sample_time)")

    def core(self) -> InertiaRequirements:
        """The numerics' requirements (without the box, which optim takes as an UncertaintyBox)."""
        return InertiaRequirements(**self.model_dump(exclude={"uncertainty"}))


#: The requirements of a request: strict JSON numbers at every depth (as the device, service.schemas.common).
InertiaRequirementsField = Annotated[InertiaRequirementsIn, WrapValidator(json_numbers(InertiaRequirementsIn))]


class InertiaRequest(BaseModel):
    model_config = {**STRICT, "json_schema_extra": {"examples": [
        {"device": _LHIFAM_FF, "requirements": {"min_gain_margin_db": 6}},
        {"device": {"preset": "lhifam"}, "requirements": {"target_apparent_mass": 0.9}},
        {"device": {"preset": "lhifam"}, "requirements": {"human_mass_range": {"min": 0.05, "max": 4}}}]}}
    device: Device
    requirements: InertiaRequirementsField = Field(default_factory=InertiaRequirementsIn)
    method: Method = MethodField()
    grid_points: GridPoints = GridPointsField()
    verify: bool = VerifyField()

    @model_validator(mode="after")
    def _in_domain(self) -> "InertiaRequest":
        """optim.domain's ratios for what the requirements add to the device: cutoffs and grasps."""
        r, dev = self.requirements, self.device
        for name in ("cutoff_min_hz", "cutoff_max_hz"):
            if getattr(r, name) is not None:
                check_cutoff_domain(getattr(r, name), dev.sample_time, f"requirements.{name}")
        for i, h in enumerate(r.humans or ()):
            check_human_domain(h, dev, f"requirements.humans.{i}")
        if r.human_mass_range is not None:
            check_human_mass(r.human_mass_range.min, dev, "requirements.human_mass_range.min")
            check_human_mass(r.human_mass_range.max, dev, "requirements.human_mass_range.max")
        return self


class ParetoPointOut(BaseModel):
    filter_cutoff_hz: float
    critical_force_gain: float | None
    force_gain: float | None = Field(description="best K_f with the required margin at this cutoff")
    apparent_mass: float | None = Field(description="m/(1 + force_gain) [kg]")


class RigidComparisonOut(BaseModel):
    critical_force_gain: float | None = Field(description="the rigid model's K_f,cr at the design's cutoff")
    force_gain: float | None = Field(description="the K_f the rigid model would have allowed")
    optimism: float | None = Field(description="K_f,cr(rigid)/K_f,cr(cable) − 1")
    optimistic: bool = Field(description="rigid model optimistic by more than 20 %")


class InertiaResponse(FiniteModel):
    status: DesignStatus = DesignStatusField()
    objective: Literal["min_apparent_mass", "target_apparent_mass"]
    force_gain: float | None = Field(description="K_f")
    filter_cutoff_hz: float | None
    filter_order: int
    apparent_mass: float | None = Field(description="m/(1 + K_f) [kg]")
    critical_force_gain: float | None = Field(description="exact K_f,cr at the design's cutoff (worst grasp)")
    gain_margin_db: float | None = Field(description="20·log10(K_f,cr/K_f) [dB]")
    crossover_frequency: float | None = Field(description="ω [rad/s] of the crossover setting K_f,cr")
    cutoff_band_hz: tuple[float, float]
    cutoff_max_source: str
    pareto: list[ParetoPointOut] = Field(description="best K_f for each cutoff over the band (exact)")
    humans: list[HumanOut] = Field(description="grasps the design holds for")
    worst_human: HumanOut | None
    human_source: str
    rigid_model: RigidComparisonOut | None
    solver: dict[str, Any]
    reason: str | None
    notes: list[str]
    elapsed_ms: float
    robust: bool = Field(default=False, description="true when requirements.uncertainty was given")
    worst_case: dict[str, Any] | None = Field(default=None, description="robust: the worst device of the box "
                                              "(device values, critical_force_gain, crossover_frequency, margin)")
    nominal_gain_margin_db: float | None = Field(default=None, description="robust: margin of the nominal device")
    apparent_mass_range: tuple[float, float] | None = Field(default=None, description="robust: m/(1 + K_f) over "
                                                            "the box's masses [kg]")
    scenarios: list[dict[str, float]] | None = Field(default=None, description="robust: box points used")
    iterations: int | None = Field(default=None, description="robust: scenario-exchange rounds")
    evaluations: int | None = Field(default=None, description="robust: exact analyses of the worst-case searches")
    method: Method = "exact"
    error_estimate: float | None = Field(None, description="relative error bound/estimate of critical_force_gain")
    error_source: str | None = None
    exact_check: ExactCheckOut | None = Field(None, description="exact margin of a linear or grid design")
    verification: VerificationOut | None = Field(None, description="present when verify was true")
