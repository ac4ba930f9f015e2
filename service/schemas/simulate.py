"""Schemas of POST /v1/simulate and POST /v1/plots/simulation."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, Field

from .common import STRICT, CrossoverOut, Device, Scene
from .finite import FiniteModel

__all__ = ["SimulateRequest", "SimulateResponse", "TrajectoryOut", "VerdictOut", "MeasuredVerdictOut", "PolesOut",
           "DominantPoleOut", "CycleOut", "SettledOut",
           "RelayOut"]


class SimulateRequest(BaseModel):
    model_config = {**STRICT, "json_schema_extra": {"examples": [
        {"device": {"preset": "lhifam", "cable": None},
         "scene": {"experiment": "release", "duration": 5.0, "controller": {"stiffness": 6500},
                   "initial": {"position": 0.001}}},
        {"device": {"preset": "lhifam", "delay": 0.003},
         "scene": {"experiment": "relay", "duration": 30.0, "relay": {"amplitude": 1.0},
                   "initial": {"position": 1e-6}, "effects": {"cable_mode": {}, "delay": {}}}}]}}
    device: Device
    scene: Scene


class TrajectoryOut(BaseModel):
    time: list[float] = Field(description="[s]")
    motor_position: list[float] = Field(description="x_r [m] (encoder side)")
    body_position: list[float] = Field(description="x_d [m]")
    force: list[float] = Field(description="commanded motor force [N]")
    energy_generated: list[float] = Field(description="energy the virtual wall generated so far [J]")


class MeasuredVerdictOut(BaseModel):
    state: Literal["stable", "unstable", "undetermined", "limit_cycle"] = Field(
        description="what the trajectory alone shows: unstable when growth is measured, stable only when every "
                    "mode the record shows decayed (below 1e-8 of the largest step, or stuck), limit_cycle "
                    "(nonlinear scenes) for a sustained oscillation, else undetermined")
    frequency: float | None = Field(description="ω of the dominant oscillation in the settled half [rad/s]")
    amplitude: float = Field(description="[m] half peak-to-peak of x_r at the end")
    growth_rate: float | None = Field(description="γ of the measured envelope [1/s]")
    reason: str
    decisive_duration: float | None = Field(
        description="[s] undetermined only: a run about this long would decide, extrapolating the measured trend "
                    "(null when no trend is measured)")


class DominantPoleOut(BaseModel):
    modulus: float = Field(description="|z| [-]")
    angle: float = Field(description="arg z [rad per sample], 0..π")
    frequency: float = Field(description="arg z / T [rad/s]")
    growth_rate: float | None = Field(description="ln|z| / T [1/s] (null when z = 0)")


class PolesOut(BaseModel):
    state: Literal["stable", "unstable", "marginal"] = Field(
        description="every pole inside the unit circle, one outside, or one on it within rounding")
    spectral_radius: float = Field(description="max |z| of the closed-loop poles [-]")
    dominant_pole: DominantPoleOut = Field(description="the pole of largest modulus")
    rounding: float | None = Field(description="[-] half-width of the interval known to hold |z| of the dominant "
                                               "pole (null when not finite: an ill-conditioned pole)")
    states: int = Field(description="size of the closed-loop state matrix")
    free_position_pole: bool = Field(description="the exact pole z = 1 of a wall without stiffness was set aside")
    linearised: bool = Field(description="true: the poles of the scene without its nonlinear effects "
                                         "(information; the measured verdict decides)")
    method: str
    reason: str


class VerdictOut(BaseModel):
    state: Literal["stable", "unstable", "undetermined", "limit_cycle"] = Field(
        description="the answer: for a linear scene the closed-loop poles decide (undetermined: a pole on the "
                    "unit circle within rounding, or the loop too large for the exact check); for a nonlinear "
                    "scene the measured verdict")
    frequency: float | None = Field(description="ω [rad/s]: of the dominant pole when the poles decide, else of "
                                                "the dominant measured oscillation")
    amplitude: float = Field(description="[m] half peak-to-peak of x_r at the end")
    growth_rate: float | None = Field(description="γ [1/s]: ln|z|/T of the dominant pole when the poles decide, "
                                                  "else of the measured envelope")
    reason: str
    decided_by: Literal["closed-loop poles", "critical stiffness", "trajectory"] = Field(
        default="trajectory", description="closed-loop poles (linear scene); critical stiffness (a linear wall "
                                          "scene beyond the poles' 600-state limit: K against K_cr(B)); trajectory")
    measured: MeasuredVerdictOut | None = None
    poles: PolesOut | None = Field(default=None, description="closed-loop poles (null for a relay, or a loop "
                                                             "larger than the exact check's limit)")
    poles_note: str | None = Field(default=None, description="why there are no poles")
    disagreement: str | None = Field(default=None, description="the measured verdict contradicts the poles "
                                                               "(said, and the poles decide)")


class CycleOut(BaseModel):
    pattern: list[int] = Field(description="half-period lengths [samples], starting with the +a half")
    period_samples: int
    frequency: float = Field(description="[rad/s]")
    force_amplitude: float = Field(description="|U₁| [N]")
    position_amplitude: float = Field(description="|Y₁| [m]")
    ultimate_gain: float | None = Field(description="K_u = |U₁|/|Y₁| [N/m]")
    admissible: bool = Field(description="the relay's sign condition holds on every sample")
    sign_margin: float = Field(description="[m] smallest signed |y| over the period (< 0: a condition fails)")


class SettledOut(BaseModel):
    repeats: bool
    pattern: list[int] | None
    symmetric: bool
    half_periods: list[int] = Field(description="settled half periods observed [samples]")
    half_period_min: int
    half_period_max: int
    frequency: float = Field(description="[rad/s]")
    force_amplitude: float = Field(description="[N]")
    position_amplitude: float = Field(description="[m]")
    ultimate_gain: float = Field(description="K_u [N/m]")
    ultimate_gain_min: float = Field(description="[N/m] smallest K_u over parts of the settled window")
    ultimate_gain_max: float = Field(description="[N/m]")
    mean_position: float = Field(description="[m] centre of the settled oscillation")
    exact: CycleOut | None = Field(description="the exact periodic solution of the pattern, when it repeats")
    force_amplitude_error: float | None
    position_amplitude_error: float | None
    frequency_error: float | None


class RelayOut(BaseModel):
    amplitude: float = Field(description="relay force a [N]")
    start_position: float = Field(description="[m]")
    start_velocity: float = Field(description="[m/s]")
    settled: SettledOut | None
    reason: str | None
    critical_stiffness: float | None = Field(description="exact K_cr [N/m] of the loop the relay closes")
    crossovers: list[CrossoverOut]
    nearest_crossover: CrossoverOut | None
    ultimate_gain_error: float | None = Field(description="(K_u - K_cr)/K_cr")
    cycles: list[CycleOut] = Field(description="every symmetric cycle N = 1 … searched_half_periods")
    admissible_half_periods: list[list[int]] = Field(description="admissible N as [first, last] runs")
    searched_half_periods: int
    admissible_gain_range: list[float] | None = Field(description="[min, max] K_u of admissible cycles [N/m]")
    notes: list[str]


class SimulateResponse(FiniteModel):
    effects_simulated: list[str]
    not_simulated: list[str] = Field(description="device blocks left out because the scene does not name them")
    method: str = Field(description="exact-linear-recursion, exact-sampled-loop or event-integrator")
    sample_time: float = Field(description="[s]")
    samples: int
    samples_run: int
    diverged_at: float | None = Field(description="[s] where a diverging run stopped")
    trajectory: TrajectoryOut
    verdict: VerdictOut
    energy_generated: float = Field(description="[J] at the end (passivity observer)")
    energy_generated_max: float = Field(description="[J]")
    energy_generated_second_half: float = Field(description="[J] generated during the second half")
    relay: RelayOut | None
    elapsed_ms: float
