"""The service's analysis answers as this client reads them (generated: see clients/schemas/__init__.py)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from clients.schemas.answer import Answer

from . import common


class BoundaryPointOut(Answer):
    damping: Annotated[float, Field(description="B [N·s/m]")]
    critical_stiffness: Annotated[float | None, Field(description="K_cr(B) [N/m]")]
    crossover_frequency: Annotated[float | None, Field(description="ω [rad/s]")]
    linear_estimate: Annotated[float, Field(description="eq. 10 [N/m]")]


class ForceCrossoverOut(Answer):
    frequency: Annotated[float, Field(description="ω [rad/s]")]
    force_gain: Annotated[float, Field(description="K_f putting a closed-loop pole at e^{jωT}")]


class BoundaryResponse(Answer):
    points: list[BoundaryPointOut]
    optimum: Annotated[BoundaryPointOut, Field(description="the B allowing the stiffest stable wall")]
    max_stable_damping: Annotated[float | None, Field(description="B_max [N·s/m]")]
    method: str
    elapsed_ms: float
    verification: Annotated[
        common.VerificationOut | None,
        Field(
            description="present when verify was true: every point verified; the optimum's record, the worst verdict"
        ),
    ] = None


class ForceFeedforwardResponse(Answer):
    critical_force_gain: Annotated[
        float | None, Field(description="K_f,cr (eq. 32/34); null when no K_f > 0 is unstable")
    ]
    crossover_frequency: Annotated[
        float | None, Field(description="ω [rad/s] of the crossover setting K_f,cr; π/T is Nyquist")
    ]
    crossovers: Annotated[list[ForceCrossoverOut], Field(description="every phase crossover with K_f > 0")]
    worst_case_force_gain: Annotated[float, Field(description="1 + m/m_h, eq. 33")]
    apparent_mass_at_critical: Annotated[
        float | None, Field(description="m/(1 + K_f,cr) [kg], the limit, not a design")
    ]
    model: Literal["rigid", "cable"]
    rigid_critical_force_gain: Annotated[float | None, Field(description="what the rigid model claims (cable devices)")]
    rigid_optimistic: Annotated[
        bool | None, Field(description="the rigid model's K_f,cr exceeds the cable model's by > 20 %")
    ]
    human: common.HumanOut
    human_source: Annotated[str, Field(description="request device, or the chapter's eq. 30 grasp when absent")]
    force_sensor_time_constant: Annotated[float, Field(description="T_f [s] used (0: no sensor filter)")]
    method: str
    elapsed_ms: float
    error_estimate: Annotated[
        float | None, Field(description="relative error bound/estimate of critical_force_gain (null when not finite)")
    ] = None
    error_source: str | None = None
    reason: str | None
    notes: list[str]
    verification: Annotated[common.VerificationOut | None, Field(description="present when verify was true")] = None


class LimitCycleOut(Answer):
    exists: Annotated[bool, Field(description="a stable (attracting) limit cycle is predicted")]
    amplitude: Annotated[float | None, Field(description="[m] amplitude (half peak-to-peak) of x_r")]
    frequency_hz: Annotated[float | None, Field(description="[Hz] its frequency")]
    threshold_amplitude: Annotated[float | None, Field(description="[m] an unstable cycle: larger motions grow")]
    method: str
    error: Annotated[str, Field(description="the method's known error (docs/quantisation.md)")]


class EnergyAuditOut(Answer):
    net_energy: Annotated[float, Field(description="[J] the wall's net energy over the push (≤ 0 when passive)")]
    port_balance_max: Annotated[float, Field(description="[J] max over time of S(t) − S(0) − user's work")]
    hold_energy: Annotated[float, Field(description="[J] the wall's energy over the hold's last quarter")]
    error_bound: Annotated[float, Field(description="[J] bound on the rounding error of net_energy")]
    active: bool
    mode: Literal["none", "instability", "chatter"]
    hold_motion_counts: Annotated[float | None, Field(description="motion over the hold's last quarter [counts]")]
    push_force: Annotated[float, Field(description="[N] the held user force")]


class NonlinearVerificationOut(Answer):
    verdict: Literal["confirmed", "contradicted", "not_checkable"]
    reason: str
    chatter_probe: EnergyAuditOut | None
    instability_probe: EnergyAuditOut | None
    measured_state: Literal["settled", "cycle", "growing", "decaying"] | None
    measured_amplitude: float | None
    measured_frequency_hz: float | None
    predicted_amplitude: float | None
    predicted_frequency_hz: float | None
    release_from: float


class NonlinearOut(Answer):
    passive_stiffness_limit: Annotated[float, Field(description="[N/m] largest passive K with this encoder and friction")]
    sampling_term: Annotated[float, Field(description="[N/m] 2b/T, or the delayed passivity limit when not covered")]
    quantization_term: Annotated[float | None, Field(description="[N/m] 2f_c/q; null (infinite) without an encoder")]
    binding: Literal["sampling", "quantization"]
    source: str
    covered: bool
    limit_cycle: LimitCycleOut
    regime: Literal["passive", "stable_not_passive", "limit_cycle", "unstable", "undetermined"] | None
    reason: str
    verification: NonlinearVerificationOut | None = None


class MassRangeOut(Answer):
    min: Annotated[float | None, Field(description="M [kg] below which the wall goes unstable; null: none")]
    max: Annotated[float | None, Field(description="M [kg] above which the wall goes unstable; null: none")]


class StabilityResponse(Answer):
    critical_stiffness: Annotated[
        float | None, Field(description="K_cr(B) [N/m]; 0 when K → 0⁺ is unstable (see stable_band); null when every K is")
    ]
    crossover_frequency: Annotated[float | None, Field(description="ω [rad/s] of the crossover that sets K_cr")]
    crossovers: Annotated[list[common.CrossoverOut], Field(description="every phase crossover with K > 0")]
    gain_margin_db: Annotated[float | None, Field(description="20·log10(K_cr/K) [dB] when a controller is given")]
    stable: bool | None
    passive: Annotated[bool | None, Field(description="delayed Colgate–Schenkel condition (ARCHITECTURE.md)")]
    passivity_required_damping: Annotated[
        float | None,
        Field(
            description=(
                "physical damping passivity needs [N·s/m]: with delay, a proven upper bound of the condition's sup"
                " over θ (at most 1e-13 of its scale K·T/2·(2d+1) + B, plus its rounding bound, above it); passive"
                " iff b exceeds it"
            )
        ),
    ]
    passivity_conservative: Annotated[bool, Field(description="a fractional delay was rounded up for passivity")]
    linear_estimate: Annotated[float, Field(description="(b + B)/(T/2 + t_d) [N/m], eq. 10")]
    linear_error: Annotated[float | None, Field(description="relative error of eq. 10 against this K_cr")]
    max_stable_damping: Annotated[
        float | None, Field(description="B_max [N·s/m]: no K > 0 is stable above it (computed when B > 0)")
    ]
    q_criterion: Annotated[float | None, Field(description="Q ≈ m_r z_n ω_n [N/m], eq. 22 (cable devices)")]
    mode_matters: Annotated[bool | None, Field(description="cable K_cr differs from the rigid model's by > 5 %")]
    rigid_critical_stiffness: Annotated[
        float | None, Field(description="K_cr of the rigid model [N/m] (cable devices)")
    ]
    damping: Annotated[float, Field(description="B [N·s/m] analysed")]
    method: str
    elapsed_ms: float
    error_estimate: Annotated[
        float | None,
        Field(
            description=(
                "relative error bound/estimate of critical_stiffness; null when unbounded (grid rung: no crossover on"
                " its grid, or its samples show crossovers it missed)"
            )
        ),
    ]
    error_source: str
    reason: str | None
    stable_band: Annotated[
        list[float | None] | None,
        Field(
            description=(
                "[K_lo, K_hi] [N/m] (K_hi null: unbounded) where critical_stiffness is 0 because B ≥ B_max but the"
                " closed loop is stable for K_lo < K < K_hi (a band not starting at 0, decided by the closed loop);"
                " null when no K > 0 is stable there, or K_cr > 0 (stable for 0 < K < K_cr)"
            )
        ),
    ] = None
    verification: Annotated[common.VerificationOut | None, Field(description="present when verify was true")] = None
    nonlinear: Annotated[
        NonlinearOut | None, Field(description="present when the device has encoder_resolution or coulomb_friction")
    ] = None
    mass_range: Annotated[
        MassRangeOut | None,
        Field(
            description=(
                "the stable virtual masses at (K, B) and this filter; present when the controller names mass or"
                " velocity_filter and a stiffness (exact rung), null when the wall is unstable"
            )
        ),
    ] = None
