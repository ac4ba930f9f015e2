"""Schemas of POST /v1/identify and POST /v1/plots/identify (contract: ARCHITECTURE.md "Identification")."""

from __future__ import annotations

from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from models.device import Device as _Device
from optim.identification.data import MAX_RESPONSE_POINTS, MAX_SAMPLES
from optim.identification.models import response as model_response

from .common import STRICT
from .finite import FiniteModel

__all__ = ["FrequencyResponseIn", "IdentifyRequest", "IdentifyResponse", "TimeSeriesIn"]

_BIG = 1e12


class TimeSeriesIn(BaseModel):
    """An experiment at the loop's rate, starting at rest (the force before the first sample was 0)."""

    model_config = STRICT
    kind: Literal["time_series"]
    sample_time: float = Field(0.001, gt=0, le=1.0, description="T, the loop's sample period [s]")
    force: list[Annotated[float, Field(ge=-_BIG, le=_BIG)]] = Field(
        max_length=MAX_SAMPLES, description="commanded motor force u[k] [N], as the ZOH holds it, one per sample")
    position: list[Annotated[float, Field(ge=-_BIG, le=_BIG)]] = Field(
        max_length=MAX_SAMPLES, description="encoder position x[k] [m] at kT (the motor side of a cable device)")


class FrequencyResponseIn(BaseModel):
    """A measured X/F [m/N] at the encoder, delay included."""

    model_config = STRICT
    kind: Literal["frequency_response"]
    frequency: list[Annotated[float, Field(gt=0, le=_BIG)]] = Field(max_length=MAX_RESPONSE_POINTS,
                                                                   description="ω [rad/s]")
    real: list[Annotated[float, Field(ge=-_BIG, le=_BIG)]] = Field(max_length=MAX_RESPONSE_POINTS,
                                                                  description="Re X/F [m/N]")
    imag: list[Annotated[float, Field(ge=-_BIG, le=_BIG)]] = Field(max_length=MAX_RESPONSE_POINTS,
                                                                  description="Im X/F [m/N]")
    response: Literal["continuous", "sampled"] = Field(
        "continuous", description="continuous: X/F(jω)·e^{−jωt_d} of the mechanics (an analyser on the "
                                  "continuous force and position); sampled: the digital loop's own G(e^{jωT}) "
                                  "from the commanded force sample to the encoder sample (ZOH included, ω < π/T)")


def _example() -> dict:
    """A swept X/F of the rigid LHifAM (5.4 kg, 3.5 N·s/m) with 1.5 ms of loop delay, 16 points 1-300 Hz."""
    w = np.geomspace(2 * np.pi, 2 * np.pi * 300, 16)
    h = model_response(_Device(mass=5.4, damping=3.5, delay=0.0015), w, "continuous")
    r6 = lambda v: [float(f"{x:.6g}") for x in v]  # noqa: E731
    return {"model": "auto", "data": {"kind": "frequency_response", "frequency": r6(w), "real": r6(h.real),
                                      "imag": r6(h.imag)}}


class IdentifyRequest(BaseModel):
    model_config = ConfigDict(**STRICT, json_schema_extra={"examples": [_example()]})
    model: Literal["rigid", "cable", "auto"] = Field(
        "auto", description="rigid | cable | auto (fit both, choose by BIC, AIC shown, say why)")
    data: TimeSeriesIn | FrequencyResponseIn = Field(discriminator="kind")
    known: dict[str, float] | None = Field(
        None, description="parameters held fixed, names as in the answer's parameters (e.g. {\"delay\": 0.0005})")
    friction: bool = Field(False, description="fit a Coulomb friction force on the motor mass (time series only)")
    confidence: float = Field(0.95, ge=0.5, lt=1.0, description="level of the confidence intervals")
    sample_time: float | None = Field(None, gt=0, le=1.0,
                                      description="the device's T [s] when data is a frequency response (default 0.001)")
    max_delay: float | None = Field(None, ge=0, le=1.0,
                                    description="the delay is searched in [0, max_delay] [s], one start per whole "
                                                "sample (default 20 samples, at most 200)")
    format: Literal["png", "svg"] | None = Field(
        None, json_schema_extra={"deprecated": True},
        description="deprecated: give ?format=png|svg in the query of /v1/plots/identify (the query wins)")


class ParameterOut(BaseModel):
    value: float = Field(description="estimate [kg, N·s/m, N/m, s or N]")
    std_error: float | None = Field(description="linearised standard error (same unit)")
    interval: list[float | None] = Field(description="[lo, hi] at the requested confidence (same unit)")


class RangeOut(BaseModel):
    min: float
    max: float


class ComparisonOut(BaseModel):
    model: Literal["rigid", "cable"]
    aic: float | None
    bic: float | None
    nrmse: float | None
    status: Literal["identified", "failed"]
    reason: str | None = None


class FitOut(BaseModel):
    nrmse: float | None = Field(description="‖residual‖/‖measured − mean‖")
    rmse: float | None = Field(description="RMS residual [m] (time series) or relative error [-] (response)")
    residual_whiteness: dict = Field(description="{test: ljung-box, lags, statistic, p_value, white, bound, "
                                                 "outside_bound}")
    residual_autocorrelation: list[float | None] = Field(description="ρ_k of the residual, k = 1..lags")
    samples: int
    evaluations: int
    starts: int


class IdentifyResponse(FiniteModel):
    status: Literal["identified", "identified_with_warnings", "failed"]
    model: Literal["rigid", "cable"] | None
    reason: str
    device: dict | None = Field(None, description="a device object every endpoint accepts")
    parameters: dict[str, ParameterOut] = Field(default_factory=dict)
    uncertainty: dict[str, RangeOut] = Field(
        default_factory=dict, description="device.<name> → {min, max}: ready for requirements.uncertainty")
    fit: FitOut | None = None
    comparison: list[ComparisonOut] = Field(default_factory=list)
    warnings: list[str] = Field(default_factory=list)
    confidence: float
    elapsed_ms: float
