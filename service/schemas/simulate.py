"""Schemas of POST /v1/simulate and POST /v1/plots/simulation."""

from __future__ import annotations

from pydantic import BaseModel, Field

from .common import STRICT, CrossoverOut, Device, Scene

__all__ = ["SimulateRequest", "SimulateResponse", "TrajectoryOut", "VerdictOut", "CycleOut", "SettledOut",
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


class VerdictOut(BaseModel):
    state: str = Field(description="stable, unstable or limit_cycle")
    frequency: float | None = Field(description="ω of the dominant oscillation [rad/s]")
    amplitude: float = Field(description="[m] half peak-to-peak of x_r at the end")
    growth_rate: float | None = Field(description="γ of the oscillation envelope [1/s]")
    reason: str


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


class SimulateResponse(BaseModel):
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
