"""The service's simulate answers as this client reads them (generated: see clients/schemas/__init__.py)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from clients.schemas.answer import Answer

from . import common


class CycleOut(Answer):
    pattern: Annotated[list[int], Field(description="half-period lengths [samples], starting with the +a half")]
    period_samples: int
    frequency: Annotated[float, Field(description="[rad/s]")]
    force_amplitude: Annotated[float, Field(description="|U₁| [N]")]
    position_amplitude: Annotated[float, Field(description="|Y₁| [m]")]
    ultimate_gain: Annotated[float | None, Field(description="K_u = |U₁|/|Y₁| [N/m]")]
    admissible: Annotated[bool, Field(description="the relay's sign condition holds on every sample")]
    sign_margin: Annotated[float, Field(description="[m] smallest signed |y| over the period (< 0: a condition fails)")]


class DominantPoleOut(Answer):
    modulus: Annotated[float, Field(description="|z| [-]")]
    angle: Annotated[float, Field(description="arg z [rad per sample], 0..π")]
    frequency: Annotated[float, Field(description="arg z / T [rad/s]")]
    growth_rate: Annotated[float | None, Field(description="ln|z| / T [1/s] (null when z = 0)")]


class MeasuredVerdictOut(Answer):
    state: Annotated[
        Literal["stable", "unstable", "undetermined", "limit_cycle"],
        Field(
            description=(
                "what the trajectory alone shows: unstable when growth is measured, stable only when every mode the"
                " record shows decayed (below 1e-8 of the largest step, or stuck), limit_cycle (nonlinear scenes) for a"
                " sustained oscillation, else undetermined"
            )
        ),
    ]
    frequency: Annotated[float | None, Field(description="ω of the dominant oscillation in the settled half [rad/s]")]
    amplitude: Annotated[float, Field(description="[m] half peak-to-peak of x_r at the end")]
    growth_rate: Annotated[float | None, Field(description="γ of the measured envelope [1/s]")]
    reason: str
    decisive_duration: Annotated[
        float | None,
        Field(
            description=(
                "[s] undetermined only: a run about this long would decide, extrapolating the measured trend (null when"
                " no trend is measured)"
            )
        ),
    ]


class PolesOut(Answer):
    state: Annotated[
        Literal["stable", "unstable", "marginal"],
        Field(description="every pole inside the unit circle, one outside, or one on it within rounding"),
    ]
    spectral_radius: Annotated[float, Field(description="max |z| of the closed-loop poles [-]")]
    dominant_pole: Annotated[DominantPoleOut, Field(description="the pole of largest modulus")]
    rounding: Annotated[
        float | None,
        Field(
            description=(
                "[-] half-width of the interval known to hold |z| of the dominant pole (null when not finite: an"
                " ill-conditioned pole)"
            )
        ),
    ]
    states: Annotated[int, Field(description="size of the closed-loop state matrix")]
    free_position_pole: Annotated[
        bool, Field(description="the exact pole z = 1 of a wall without stiffness was set aside")
    ]
    linearised: Annotated[
        bool,
        Field(
            description=(
                "true: the poles of the scene without its nonlinear effects (information; the measured verdict decides)"
            )
        ),
    ]
    method: str
    reason: str


class SettledOut(Answer):
    repeats: bool
    pattern: list[int] | None
    symmetric: bool
    half_periods: Annotated[list[int], Field(description="settled half periods observed [samples]")]
    half_period_min: int
    half_period_max: int
    frequency: Annotated[float, Field(description="[rad/s]")]
    force_amplitude: Annotated[float, Field(description="[N]")]
    position_amplitude: Annotated[float, Field(description="[m]")]
    ultimate_gain: Annotated[float, Field(description="K_u [N/m]")]
    ultimate_gain_min: Annotated[float, Field(description="[N/m] smallest K_u over parts of the settled window")]
    ultimate_gain_max: Annotated[float, Field(description="[N/m]")]
    mean_position: Annotated[float, Field(description="[m] centre of the settled oscillation")]
    exact: Annotated[CycleOut | None, Field(description="the exact periodic solution of the pattern, when it repeats")]
    force_amplitude_error: float | None
    position_amplitude_error: float | None
    frequency_error: float | None


class TrajectoryOut(Answer):
    time: Annotated[list[float], Field(description="[s]")]
    motor_position: Annotated[list[float], Field(description="x_r [m] (encoder side)")]
    body_position: Annotated[list[float], Field(description="x_d [m]")]
    force: Annotated[list[float], Field(description="commanded motor force [N]")]
    energy_generated: Annotated[list[float], Field(description="energy the virtual wall generated so far [J]")]


class VerdictOut(Answer):
    state: Annotated[
        Literal["stable", "unstable", "undetermined", "limit_cycle"],
        Field(
            description=(
                "the answer: for a linear scene the closed-loop poles decide (undetermined: a pole on the unit circle"
                " within rounding, or the loop too large for the exact check); for a nonlinear scene the measured"
                " verdict"
            )
        ),
    ]
    frequency: Annotated[
        float | None,
        Field(
            description=(
                "ω [rad/s]: of the dominant pole when the poles decide, else of the dominant measured oscillation"
            )
        ),
    ]
    amplitude: Annotated[float, Field(description="[m] half peak-to-peak of x_r at the end")]
    growth_rate: Annotated[
        float | None,
        Field(description="γ [1/s]: ln|z|/T of the dominant pole when the poles decide, else of the measured envelope"),
    ]
    reason: str
    decided_by: Annotated[
        Literal["closed-loop poles", "critical stiffness", "trajectory"],
        Field(
            description=(
                "closed-loop poles (linear scene); critical stiffness (a linear wall scene beyond the poles' 600-state"
                " limit: K against K_cr(B)); trajectory"
            )
        ),
    ] = "trajectory"
    measured: MeasuredVerdictOut | None = None
    poles: Annotated[
        PolesOut | None,
        Field(description="closed-loop poles (null for a relay, or a loop larger than the exact check's limit)"),
    ] = None
    poles_note: Annotated[str | None, Field(description="why there are no poles")] = None
    disagreement: Annotated[
        str | None, Field(description="the measured verdict contradicts the poles (said, and the poles decide)")
    ] = None


class RelayOut(Answer):
    amplitude: Annotated[float, Field(description="relay force a [N]")]
    start_position: Annotated[float, Field(description="[m]")]
    start_velocity: Annotated[float, Field(description="[m/s]")]
    settled: SettledOut | None
    reason: str | None
    critical_stiffness: Annotated[float | None, Field(description="exact K_cr [N/m] of the loop the relay closes")]
    crossovers: list[common.CrossoverOut]
    nearest_crossover: common.CrossoverOut | None
    ultimate_gain_error: Annotated[float | None, Field(description="(K_u - K_cr)/K_cr")]
    cycles: Annotated[list[CycleOut], Field(description="every symmetric cycle N = 1 … searched_half_periods")]
    admissible_half_periods: Annotated[list[list[int]], Field(description="admissible N as [first, last] runs")]
    searched_half_periods: int
    admissible_gain_range: Annotated[list[float] | None, Field(description="[min, max] K_u of admissible cycles [N/m]")]
    notes: list[str]


class SimulateResponse(Answer):
    effects_simulated: list[str]
    not_simulated: Annotated[
        list[str], Field(description="device blocks left out because the scene does not name them")
    ]
    method: Annotated[str, Field(description="exact-linear-recursion, exact-sampled-loop or event-integrator")]
    sample_time: Annotated[float, Field(description="[s]")]
    samples: int
    samples_run: int
    diverged_at: Annotated[float | None, Field(description="[s] where a diverging run stopped")]
    trajectory: TrajectoryOut
    verdict: VerdictOut
    energy_generated: Annotated[float, Field(description="[J] at the end (passivity observer)")]
    energy_generated_max: Annotated[float, Field(description="[J]")]
    energy_generated_second_half: Annotated[float, Field(description="[J] generated during the second half")]
    relay: RelayOut | None
    elapsed_ms: float
