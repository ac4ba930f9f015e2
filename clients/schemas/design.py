"""The service's design answers as this client reads them (generated: see clients/schemas/__init__.py)."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import Field

from clients.schemas.answer import Answer

from . import common


class ControllerOut(Answer):
    stiffness: Annotated[float | None, Field(description="the target K [N/m]")] = None
    damping: Annotated[float | None, Field(description="B of the best controller at the loosest value [N·s/m]")] = None
    achievable_stiffness: Annotated[
        float | None,
        Field(description="largest K at that value [N/m] (= target at the edge when the stiffness limits)"),
    ] = None
    gain_margin_db: Annotated[float | None, Field(description="exact margin of the target K with that B [dB]")] = None
    force_gain: Annotated[
        float | None,
        Field(
            description=(
                "the K_f the target needs at that value (m/m_app − 1 for an apparent-mass target, 0 when not needed)"
            )
        ),
    ] = None
    filter_cutoff_hz: Annotated[float | None, Field(description="cutoff with the largest critical force gain [Hz]")] = (
        None
    )
    filter_order: int | None = None
    achievable_force_gain: Annotated[
        float | None, Field(description="largest K_f at that value (= the needed K_f at the edge when it limits)")
    ] = None
    apparent_mass: Annotated[float | None, Field(description="m/(1 + force_gain) [kg]")] = None
    critical_force_gain: Annotated[float | None, Field(description="exact K_f,cr at that cutoff")] = None
    force_gain_margin_db: Annotated[float | None, Field(description="20·log10(K_f,cr/force_gain) [dB]")] = None


class CurvePoint(Answer):
    value: Annotated[float, Field(description="the free parameter [SI]")]
    achievable_stiffness: Annotated[
        float | None,
        Field(description="largest K with the margin at this value [N/m] (0: none; null without a stiffness target)"),
    ] = None
    damping: Annotated[float | None, Field(description="the B that achieves it [N·s/m]")] = None
    achievable_force_gain: Annotated[
        float | None,
        Field(
            description=(
                "largest K_f with the margin, best over the cutoff band (null without a force-feedforward target, or"
                " when the model bounds none)"
            )
        ),
    ] = None
    filter_cutoff_hz: Annotated[
        float | None, Field(description="the cutoff where it is reached [Hz] (null: no cutoff in the band)")
    ] = None
    apparent_mass: Annotated[float | None, Field(description="m/(1 + achievable K_f) at this value [kg]")] = None


class EdgeOut(Answer):
    value: Annotated[float, Field(description="an edge of the feasible set [SI]")]
    limiting_target: Annotated[
        Literal["stiffness", "force_gain", "apparent_mass"], Field(description="the target that binds there")
    ]


class ExactCheckOut(Answer):
    """
    The exact analysis of a design produced by an approximate rung (linear, grid).
    """

    critical_value: Annotated[
        float | None, Field(description="exact K_cr(B) [N/m] (stiffness) or K_f,cr at the cutoff (inertia)")
    ]
    gain_margin_db: Annotated[float | None, Field(description="exact margin of the design [dB]")]
    meets_min_gain_margin: bool
    stable: bool
    passive: Annotated[bool | None, Field(description="exact delayed passivity (when passivity was required)")] = None
    statement: Annotated[str, Field(description="'safe: …' or 'UNSAFE: …'")]


class ParetoPointOut(Answer):
    filter_cutoff_hz: float
    critical_force_gain: float | None
    force_gain: Annotated[float | None, Field(description="best K_f with the required margin at this cutoff")]
    apparent_mass: Annotated[float | None, Field(description="m/(1 + force_gain) [kg]")]


class PassivityWorstCaseOut(Answer):
    device: Annotated[dict[str, float], Field(description="box values of the least passive device (SI)")]
    delay_samples_used: Annotated[int, Field(description="whole samples of delay its passivity test uses, ⌈t_d/T⌉")]
    approached: Annotated[
        bool,
        Field(
            description=(
                "true when the box only approaches it: devices with the sample time just below this one have that many"
                " samples (at it the delay is one sample less)"
            )
        ),
    ]
    damping: Annotated[float, Field(description="its physical damping b [N·s/m] (the box's smallest)")]
    required_damping: Annotated[float, Field(description="sup over θ of P(θ) at the design [N·s/m]")]
    passivity_margin: Annotated[float, Field(description="b − sup P [N·s/m]: ≥ 0, ≈ 0 when passivity binds")]
    worst_angle: Annotated[float | None, Field(description="θ = ωT where P is largest [rad per sample]")] = None


class RenderedFilterOut(Answer):
    kind: Annotated[
        str,
        Field(description="the velocity filter: backward_difference, low_pass, moving_average, transfer_function"),
    ]
    cutoff_hz: Annotated[float | None, Field(description="f of a low-pass [Hz] (designed or given)")] = None
    order: Annotated[int | None, Field(description="low-pass order")] = None
    designed: Annotated[bool, Field(description="true when the design chose the cutoff")]
    min_cutoff_hz: Annotated[float | None, Field(description="the designed cutoff's range [Hz]")] = None
    max_cutoff_hz: float | None = None
    mass: Annotated[float, Field(description="virtual mass M [kg]")] = 0.0
    step_peak: Annotated[
        float, Field(description="max_k |s_k| [1/s]: the velocity estimate after a unit position step")
    ]
    noise_gain: Annotated[
        float, Field(description="sqrt(Σh_k²) [1/s]: rms velocity estimate per unit white position noise")
    ]
    force_step: Annotated[
        float | None,
        Field(description="B·q·max|s_k| [N]: the damper force step of one encoder count (with requirements.quantization)"),
    ] = None
    force_noise_rms: Annotated[float | None, Field(description="B·q·sqrt(Σh_k²/12) [N rms] (with quantization)")] = None
    crossover_cutoff_ratio: Annotated[
        float | None, Field(description="the critical crossover's ω/(2π) over the cutoff")
    ] = None
    note: str | None = None


class RigidComparisonOut(Answer):
    critical_force_gain: Annotated[float | None, Field(description="the rigid model's K_f,cr at the design's cutoff")]
    force_gain: Annotated[float | None, Field(description="the K_f the rigid model would have allowed")]
    optimism: Annotated[float | None, Field(description="K_f,cr(rigid)/K_f,cr(cable) − 1")]
    optimistic: Annotated[bool, Field(description="rigid model optimistic by more than 20 %")]


class SensitivityOut(Answer):
    parameter: Literal["damping", "delay", "sample_time", "mass"]
    derivative: Annotated[float, Field(description="dK*/dq, re-optimised [N/m per SI unit of q]")]
    step: Annotated[float, Field(description="a designer's step of q [SI unit of q]")]
    step_label: str
    change: Annotated[float, Field(description="derivative·step [N/m]")]
    statement: str


class WorstCaseOut(Answer):
    device: Annotated[dict[str, float], Field(description="the worst device's values of the uncertain paths (SI)")]
    critical_stiffness: Annotated[float, Field(description="exact K_cr(B) of the worst device [N/m]")]
    crossover_frequency: Annotated[float | None, Field(description="ω of its critical crossover [rad/s]")] = None
    gain_margin_db: Annotated[float | None, Field(description="20·log10(K_cr/K) of the worst device [dB]")] = None


class WorkspaceCaseOut(Answer):
    pose: Annotated[list[float], Field(description="joint values [rad or m]")]
    normal: Annotated[list[float], Field(description="unit wall normal in the base frame")]
    critical_stiffness: Annotated[float | None, Field(description="K_cr at the design's B [N/m]")]


class MimoCheckOut(Answer):
    pose: list[float]
    normal: list[float]
    spectral_radius: Annotated[
        float, Field(description="max |z| of the full MIMO sampled loop at the design's (K, B)")
    ]
    stable: bool


class WorkspaceDesignOut(Answer):
    worst_cases: Annotated[list[WorkspaceCaseOut], Field(description="the exchange's active (pose, normal) set")]
    exchanges: int
    design_poses: int
    verification_poses: Annotated[
        int, Field(description="poses of the denser set (a Latin hypercube and the design poses)")
    ]
    verification_worst: Annotated[
        WorkspaceCaseOut | None, Field(description="the denser set's lowest K_cr at the design's B")
    ]
    verification_margin: Annotated[
        float | None, Field(description="that K_cr / K − 1: ≥ 0 when the design holds there")
    ]
    mimo_checks: Annotated[
        list[MimoCheckOut],
        Field(description="verify: the full MIMO loop at the worst cases and the denser set's worst"),
    ] = Field(default_factory=list)
    note: str


class HardwareDesignResponse(Answer):
    status: Literal["optimal", "infeasible", "failed"]
    free: str
    direction: Annotated[Literal["max", "min"], Field(description="the direction in which the hardware gets looser")]
    value: Annotated[float | None, Field(description="loosest value of the free parameter that renders the target")] = (
        None
    )
    bounded: Annotated[bool, Field(description="false: the target holds to the end of the scanned range")] = True
    controller: ControllerOut | None = None
    intervals: Annotated[list[list[Any]], Field(default_factory=list, description="feasible set (intervals)")]
    edges: Annotated[
        list[EdgeOut],
        Field(default_factory=list, description="edges of the feasible set and the target binding at each"),
    ]
    curve: Annotated[list[CurvePoint], Field(default_factory=list, description="trade-off curve")]
    best_value: Annotated[
        float | None,
        Field(
            description="value of the free parameter where the targets are best met (largest smallest relative excess)"
        ),
    ] = None
    best_achievable_stiffness: Annotated[float | None, Field(description="K* at best_value [N/m]")] = None
    best_achievable_force_gain: Annotated[float | None, Field(description="K_f* at best_value")] = None
    best_apparent_mass: Annotated[float | None, Field(description="m/(1 + K_f*) at best_value [kg]")] = None
    matters: Annotated[
        bool, Field(description="false: no achievable value changes by > 0.1 % over the scanned range")
    ] = True
    limiting_target: Annotated[
        Literal["stiffness", "force_gain", "apparent_mass"] | None,
        Field(description="the target that sets the answer (infeasible: the one furthest from reach at best_value)"),
    ] = None
    reason: str | None = None
    note: str | None = None
    limiting_effect: Annotated[
        str | None,
        Field(
            description=(
                "the physical effect that sets the answer; infeasible: measured at best_value (which ×2 change of"
                " another parameter helps most)"
            )
        ),
    ] = None
    scanned_range: Annotated[list[Any] | None, Field(description="the range of the free parameter scanned")] = None
    range_source: Annotated[
        str | None,
        Field(
            description=(
                "request, the default span, or how it was widened and what stopped it (a physical bound, an input"
                " limit, no improvement)"
            )
        ),
    ] = None
    elapsed_ms: float
    verification: Annotated[
        common.VerificationOut | None,
        Field(description="present when verify was true: the target controller checked at the answer's value"),
    ] = None
    quantisation: Annotated[
        dict[str, Any] | None,
        Field(
            description=(
                "free = encoder_resolution | coulomb_friction: the passive limit's terms, the counts over"
                " device.travel, and the nonlinear analysis at the answer and 1 % looser"
                " (optim/hardware/quantisation.py)"
            )
        ),
    ] = None


class InertiaResponse(Answer):
    status: Annotated[
        Literal["optimal", "infeasible", "failed", "unsafe"],
        Field(
            description=(
                "optimal; infeasible or failed (reason says why); unsafe: the design of an approximate rung (method"
                " linear or grid) fails its own exact check (reason and exact_check give the exact margin)"
            )
        ),
    ]
    objective: Literal["min_apparent_mass", "target_apparent_mass"]
    force_gain: Annotated[float | None, Field(description="K_f")]
    filter_cutoff_hz: float | None
    filter_order: int
    apparent_mass: Annotated[float | None, Field(description="m/(1 + K_f) [kg]")]
    critical_force_gain: Annotated[float | None, Field(description="exact K_f,cr at the design's cutoff (worst grasp)")]
    gain_margin_db: Annotated[float | None, Field(description="20·log10(K_f,cr/K_f) [dB]")]
    crossover_frequency: Annotated[float | None, Field(description="ω [rad/s] of the crossover setting K_f,cr")]
    cutoff_band_hz: list[Any]
    cutoff_max_source: str
    pareto: Annotated[list[ParetoPointOut], Field(description="best K_f for each cutoff over the band (exact)")]
    humans: Annotated[list[common.HumanOut], Field(description="grasps the design holds for")]
    worst_human: common.HumanOut | None
    human_source: str
    rigid_model: RigidComparisonOut | None
    solver: dict[str, Any]
    reason: str | None
    notes: list[str]
    elapsed_ms: float
    robust: Annotated[bool, Field(description="true when requirements.uncertainty was given")] = False
    worst_case: Annotated[
        dict[str, Any] | None,
        Field(
            description=(
                "robust: the worst device of the box (device values, critical_force_gain, crossover_frequency, margin)"
            )
        ),
    ] = None
    nominal_gain_margin_db: Annotated[float | None, Field(description="robust: margin of the nominal device")] = None
    apparent_mass_range: Annotated[
        list[Any] | None, Field(description="robust: m/(1 + K_f) over the box's masses [kg]")
    ] = None
    scenarios: Annotated[list[dict[str, float]] | None, Field(description="robust: box points used")] = None
    iterations: Annotated[int | None, Field(description="robust: scenario-exchange rounds")] = None
    evaluations: Annotated[int | None, Field(description="robust: exact analyses of the worst-case searches")] = None
    method: Literal["linear", "grid", "exact", "reference"] = "exact"
    error_estimate: Annotated[
        float | None, Field(description="relative error bound/estimate of critical_force_gain")
    ] = None
    error_source: str | None = None
    exact_check: Annotated[ExactCheckOut | None, Field(description="exact margin of a linear or grid design")] = None
    verification: Annotated[common.VerificationOut | None, Field(description="present when verify was true")] = None


class StiffnessDesignResponse(Answer):
    status: Annotated[
        Literal["optimal", "infeasible", "failed", "unsafe"],
        Field(
            description=(
                "optimal; infeasible or failed (reason says why); unsafe: the design of an approximate rung (method"
                " linear or grid) fails its own exact check (reason and exact_check give the exact margin)"
            )
        ),
    ]
    stiffness: Annotated[float | None, Field(description="K [N/m]")] = None
    damping: Annotated[float | None, Field(description="B [N·s/m]")] = None
    critical_stiffness: Annotated[float | None, Field(description="exact K_cr at the chosen B [N/m]")] = None
    gain_margin_db: Annotated[float | None, Field(description="exact 20·log10(K_cr/K) [dB]")] = None
    crossover_frequency: Annotated[float | None, Field(description="ω of the crossover that sets K_cr [rad/s]")] = None
    linear_estimate: Annotated[float | None, Field(description="eq. 10 at the chosen B, (b + B)/(T/2 + t_d) [N/m]")] = (
        None
    )
    linear_estimate_error: Annotated[float | None, Field(description="(linear − exact)/exact K_cr at the chosen B")] = (
        None
    )
    max_stable_damping: Annotated[float | None, Field(description="B_max: no K > 0 is stable above it [N·s/m]")] = None
    active_constraints: list[str] = Field(default_factory=list)
    back_off: Annotated[
        float | None,
        Field(
            description=(
                "K sits at least this far (relative, 1e-8) below the limits the analysis checks (g·K_cr(B), the passive"
                " K), so the design is strictly inside them; caps on K are met as K ≤ cap; null on the linear and grid"
                " rungs"
            )
        ),
    ] = None
    sensitivities: list[SensitivityOut] = Field(default_factory=list)
    sensitivity_note: str | None = None
    passivity_delay_samples: Annotated[
        int | None, Field(description="whole samples of delay used by the passivity test")
    ] = None
    passivity_note: str | None = None
    reason: str | None = None
    rendered: Annotated[
        RenderedFilterOut | None,
        Field(description="the rendered wall's velocity filter (given or designed), virtual mass and damper noise; "
                          "absent for today's wall"),
    ] = None
    solver: dict[str, Any] = Field(default_factory=dict)
    elapsed_ms: float
    setup_ms: Annotated[float | None, Field(description="boundary sampling and seeding [ms]")] = None
    solve_ms: Annotated[float | None, Field(description="NLP solves, exact re-checks and sensitivities [ms]")] = None
    robust: Annotated[bool, Field(description="true when requirements.uncertainty was given")] = False
    worst_case: Annotated[WorstCaseOut | None, Field(description="robust design: the worst device of the box")] = None
    nominal_gain_margin_db: Annotated[
        float | None, Field(description="robust design: margin of the nominal device [dB]")
    ] = None
    scenarios: Annotated[list[dict[str, float]] | None, Field(description="robust design: box points the NLP used")] = (
        None
    )
    iterations: Annotated[int | None, Field(description="robust design: scenario-exchange rounds")] = None
    evaluations: Annotated[
        int | None, Field(description="robust design: exact analyses of the worst-case searches")
    ] = None
    ignored_paths: Annotated[
        list[str] | None,
        Field(description="uncertain paths that do not enter the stiffness loop (the user's grasp, the force sensor)"),
    ] = None
    passivity_worst_case: Annotated[
        PassivityWorstCaseOut | None,
        Field(description="robust design with passivity: the least passive device of the box and its margin"),
    ] = None
    method: Literal["linear", "grid", "exact", "reference"] = "exact"
    error_estimate: Annotated[
        float | None, Field(description="relative error bound/estimate of critical_stiffness")
    ] = None
    error_source: str | None = None
    exact_check: Annotated[ExactCheckOut | None, Field(description="exact margin of a linear or grid design")] = None
    verification: Annotated[common.VerificationOut | None, Field(description="present when verify was true")] = None
    workspace: Annotated[
        WorkspaceDesignOut | None,
        Field(description="workspace design: its worst cases and the denser set's verification"),
    ] = None
