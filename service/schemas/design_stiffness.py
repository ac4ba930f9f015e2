"""Request and response of POST /v1/design/stiffness."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_serializer, model_validator

from models.velocity_filter import rendering
from optim.domain import check_controller_domain
from optim.errors import InputError
from optim.stiffness.requirements import StiffnessRequirements

from .common import (
    Device,  # the numerics' validated domain (optim.domain) applies
    RenderedEnvironment,
)
from .finite import FiniteModel
from .ladder import DesignStatus, DesignStatusField, ExactCheckOut, GridPoints, GridPointsField, Method, MethodField
from .verification import VerificationOut, VerifyField
from .workspace import Kinematics, Poses

__all__ = ["StiffnessRequirementsIn", "StiffnessDesignRequest", "SensitivityOut", "StiffnessDesignResponse",
           "RangeIn", "WorstCaseOut", "PassivityWorstCaseOut", "RenderedFilterOut"]

_STRICT = ConfigDict(extra="forbid", allow_inf_nan=False, strict=True)


class RangeIn(BaseModel):
    """A closed range of one uncertain device parameter (SI unit of that parameter)."""

    model_config = _STRICT
    min: float
    max: float


class WorkspaceRequirementIn(BaseModel):
    """The pose set and normals of the workspace design (the shapes of POST /v1/analysis/workspace)."""

    model_config = _STRICT
    kinematics: Kinematics
    poses: Poses
    normals: list[list[float]] | Literal["worst"] = Field(
        "worst", description="unit wall normals in the base frame, or \"worst\": each pose's worst normal")
    verify_factor: int = Field(4, ge=1, le=16, description="the verification's denser set: this many times the "
                                                            "design poses (a Latin hypercube) plus the design poses")


class StiffnessRequirementsIn(StiffnessRequirements):
    """Every limit but the gain margin is optional and acts only when given."""

    # The fields, bounds, pairing rules and their messages are optim's (one source); the request adds JSON-number
    # strictness and the robust design's box.
    model_config = _STRICT

    uncertainty: dict[str, RangeIn] | None = Field(
        None, description="robust design: dotted device paths (device.mass, device.delay, device.cable.stiffness, "
                          "…) mapped to {min, max}; the design then holds for every device of the box")

    workspace: WorkspaceRequirementIn | None = Field(
        None, description="workspace design: one (K, B) stable at every pose and normal of a multi-DOF device "
                          "(docs/workspace.md); the device's sample_time and delay are the loop's, its mass and "
                          "damping are not used")

    def core(self) -> StiffnessRequirements:
        """The numerics' requirements (without the box, which optim takes as an UncertaintyBox)."""
        return StiffnessRequirements(**self.model_dump(exclude={"uncertainty", "workspace"}))


class StiffnessDesignRequest(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, strict=True, json_schema_extra={"examples": [
        {"device": {"mass": 5.4, "damping": 3.5, "sample_time": 0.001}, "requirements": {"min_gain_margin_db": 6}},
        {"device": {"preset": "lhifam"}, "requirements": {"min_gain_margin_db": 6}},
        {"device": {"preset": "phantom-1.0"}}]})

    device: Device
    requirements: StiffnessRequirementsIn = Field(default_factory=StiffnessRequirementsIn)
    controller: RenderedEnvironment | None = Field(
        default=None, description="the rendered wall's virtual mass and fixed velocity filter (ARCHITECTURE.md, "
                                  "\"The rendered virtual environment\"); a designed cutoff goes in "
                                  "requirements.velocity_filter")
    method: Method = MethodField()
    grid_points: GridPoints = GridPointsField()
    verify: bool = VerifyField()

    @model_validator(mode="after")
    def _filter_fits_the_device(self) -> "StiffnessDesignRequest":
        """The filter's rules that need T (a cutoff or cutoff range below Nyquist, a stable velocity estimate), as
        422s naming the field; one filter only."""
        from optim.stiffness.rendered_design import check_design_filter

        c = self.controller
        if c is not None and c.velocity_filter is not None and self.requirements.velocity_filter is not None:
            raise InputError("requirements.velocity_filter", "give the velocity filter once: in controller (a fixed "
                                                              "filter) or in requirements (fixed or designed), not both")
        if c is not None and c.rendered:
            try:
                rendering(c.velocity_filter, c.mass, self.device.sample_time)
            except InputError as exc:
                raise exc.under("controller.") from None
        check_design_filter(self.requirements, self.device.sample_time)
        return self

    @model_validator(mode="after")
    def _in_domain(self) -> "StiffnessDesignRequest":
        """optim.domain: every cap on K or B, made dimensionless by the device (α = K·T²/m, β = B·T/m), within
        range; the derived caps K ≤ F/x and B ≤ F_noise·T/q are named by their force."""
        r, dev = self.requirements, self.device
        if r.workspace is not None:   # the arm's M(q) sets the scale, not the device's mass: optim checks the design
            return self
        if r.max_damping is not None:
            check_controller_domain(r.max_damping, dev, "damping", "requirements.max_damping")
        if r.max_stiffness is not None:
            check_controller_domain(r.max_stiffness, dev, "stiffness", "requirements.max_stiffness")
        if r.max_force is not None and r.max_penetration is not None:
            check_controller_domain(r.max_force / r.max_penetration, dev, "stiffness", "requirements.max_force")
        if r.quantization is not None and r.max_force_noise is not None:
            check_controller_domain(r.max_force_noise * dev.sample_time / r.quantization, dev, "damping",
                                    "requirements.max_force_noise")
        return self


class SensitivityOut(BaseModel):
    parameter: Literal["damping", "delay", "sample_time", "mass"]
    derivative: float = Field(description="dK*/dq, re-optimised [N/m per SI unit of q]")
    step: float = Field(description="a designer's step of q [SI unit of q]")
    step_label: str
    change: float = Field(description="derivative·step [N/m]")
    statement: str


class WorstCaseOut(BaseModel):
    device: dict[str, float] = Field(description="the worst device's values of the uncertain paths (SI)")
    critical_stiffness: float = Field(description="exact K_cr(B) of the worst device [N/m]")
    crossover_frequency: float | None = Field(None, description="ω of its critical crossover [rad/s]")
    gain_margin_db: float | None = Field(None, description="20·log10(K_cr/K) of the worst device [dB]")


class PassivityWorstCaseOut(BaseModel):
    device: dict[str, float] = Field(description="box values of the least passive device (SI)")
    delay_samples_used: int = Field(description="whole samples of delay its passivity test uses, ⌈t_d/T⌉")
    approached: bool = Field(description="true when the box only approaches it: devices with the sample time just "
                                         "below this one have that many samples (at it the delay is one sample less)")
    damping: float = Field(description="its physical damping b [N·s/m] (the box's smallest)")
    required_damping: float = Field(description="sup over θ of P(θ) at the design [N·s/m]")
    passivity_margin: float = Field(description="b − sup P [N·s/m]: ≥ 0, ≈ 0 when passivity binds")
    worst_angle: float | None = Field(None, description="θ = ωT where P is largest [rad per sample]")


class WorkspaceCaseOut(FiniteModel):
    pose: list[float] = Field(description="joint values [rad or m]")
    normal: list[float] = Field(description="unit wall normal in the base frame")
    critical_stiffness: float | None = Field(description="K_cr at the design's B [N/m]")


class MimoCheckOut(FiniteModel):
    pose: list[float]
    normal: list[float]
    spectral_radius: float = Field(description="max |z| of the full MIMO sampled loop at the design's (K, B)")
    stable: bool


class WorkspaceDesignOut(FiniteModel):
    worst_cases: list[WorkspaceCaseOut] = Field(description="the exchange's active (pose, normal) set")
    exchanges: int
    design_poses: int
    verification_poses: int = Field(description="poses of the denser set (a Latin hypercube and the design poses)")
    verification_worst: WorkspaceCaseOut | None = Field(description="the denser set's lowest K_cr at the design's B")
    verification_margin: float | None = Field(description="that K_cr / K − 1: ≥ 0 when the design holds there")
    mimo_checks: list[MimoCheckOut] = Field(default_factory=list, description="verify: the full MIMO loop at the "
                                                                              "worst cases and the denser set's worst")
    note: str


class RenderedFilterOut(BaseModel):
    kind: str = Field(description="the velocity filter: backward_difference, low_pass, moving_average, "
                                  "transfer_function")
    cutoff_hz: float | None = Field(None, description="f of a low-pass [Hz] (designed or given)")
    order: int | None = Field(None, description="low-pass order")
    designed: bool = Field(description="true when the design chose the cutoff")
    min_cutoff_hz: float | None = Field(None, description="the designed cutoff's range [Hz]")
    max_cutoff_hz: float | None = None
    mass: float = Field(0.0, description="virtual mass M [kg]")
    step_peak: float = Field(description="max_k |s_k| [1/s]: the velocity estimate after a unit position step")
    noise_gain: float = Field(description="sqrt(Σh_k²) [1/s]: rms velocity estimate per unit white position noise")
    force_step: float | None = Field(None, description="B·q·max|s_k| [N]: the damper force step of one encoder "
                                                       "count (with requirements.quantization)")
    force_noise_rms: float | None = Field(None, description="B·q·sqrt(Σh_k²/12) [N rms] (with quantization)")
    crossover_cutoff_ratio: float | None = Field(None, description="the critical crossover's ω/(2π) over the "
                                                                   "cutoff")
    note: str | None = None


class StiffnessDesignResponse(FiniteModel):
    status: DesignStatus = DesignStatusField()
    stiffness: float | None = Field(None, description="K [N/m]")
    damping: float | None = Field(None, description="B [N·s/m]")
    critical_stiffness: float | None = Field(None, description="exact K_cr at the chosen B [N/m]")
    gain_margin_db: float | None = Field(None, description="exact 20·log10(K_cr/K) [dB]")
    crossover_frequency: float | None = Field(None, description="ω of the crossover that sets K_cr [rad/s]")
    linear_estimate: float | None = Field(None, description="eq. 10 at the chosen B, (b + B)/(T/2 + t_d) [N/m]")
    linear_estimate_error: float | None = Field(None, description="(linear − exact)/exact K_cr at the chosen B")
    max_stable_damping: float | None = Field(None, description="B_max: no K > 0 is stable above it [N·s/m]")
    active_constraints: list[str] = Field(default_factory=list)
    back_off: float | None = Field(None, description="K sits at least this far (relative, 1e-8) below the limits "
                                                     "the analysis checks (g·K_cr(B), the passive K), so the design "
                                                     "is strictly inside them; caps on K are met as K ≤ cap; null "
                                                     "on the linear and grid rungs")
    sensitivities: list[SensitivityOut] = Field(default_factory=list)
    sensitivity_note: str | None = None
    passivity_delay_samples: int | None = Field(None, description="whole samples of delay used by the passivity test")
    passivity_note: str | None = None
    reason: str | None = None
    rendered: RenderedFilterOut | None = Field(None, description="the rendered wall's velocity filter (given or "
                                                                 "designed), virtual mass and damper noise; absent "
                                                                 "for today's wall")
    solver: dict = Field(default_factory=dict)
    elapsed_ms: float
    setup_ms: float | None = Field(None, description="boundary sampling and seeding [ms]")
    solve_ms: float | None = Field(None, description="NLP solves, exact re-checks and sensitivities [ms]")
    robust: bool = Field(False, description="true when requirements.uncertainty was given")
    worst_case: WorstCaseOut | None = Field(None, description="robust design: the worst device of the box")
    nominal_gain_margin_db: float | None = Field(None, description="robust design: margin of the nominal device [dB]")
    scenarios: list[dict[str, float]] | None = Field(None, description="robust design: box points the NLP used")
    iterations: int | None = Field(None, description="robust design: scenario-exchange rounds")
    evaluations: int | None = Field(None, description="robust design: exact analyses of the worst-case searches")
    ignored_paths: list[str] | None = Field(None, description="uncertain paths that do not enter the stiffness loop "
                                                             "(the user's grasp, the force sensor)")
    passivity_worst_case: PassivityWorstCaseOut | None = Field(
        None, description="robust design with passivity: the least passive device of the box and its margin")
    method: Method = "exact"
    error_estimate: float | None = Field(None, description="relative error bound/estimate of critical_stiffness")
    error_source: str | None = None
    exact_check: ExactCheckOut | None = Field(None, description="exact margin of a linear or grid design")
    verification: VerificationOut | None = Field(None, description="present when verify was true")
    workspace: WorkspaceDesignOut | None = Field(None, description="workspace design: its worst cases and the "
                                                                   "denser set's verification")

    @model_serializer(mode="wrap")
    def _omit_absent_rendering(self, handler):   # unannotated: the response schema stays the model's own
        # today's designs answer exactly as before: each block appears only for a rendered wall or a workspace design
        data = handler(self)
        if data.get("rendered", 0) is None:
            del data["rendered"]
        if data.get("workspace", 0) is None:
            del data["workspace"]
        return data
