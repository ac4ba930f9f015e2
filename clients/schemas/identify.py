"""The service's identify answers as this client reads them (generated: see clients/schemas/__init__.py)."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import Field

from clients.schemas.answer import Answer


class ComparisonOut(Answer):
    model: Literal["rigid", "cable"]
    aic: float | None
    bic: float | None
    nrmse: float | None
    status: Literal["identified", "failed"]
    reason: str | None = None


class FitOut(Answer):
    nrmse: Annotated[float | None, Field(description="‖residual‖/‖measured − mean‖")]
    rmse: Annotated[float | None, Field(description="RMS residual [m] (time series) or relative error [-] (response)")]
    residual_whiteness: Annotated[
        dict[str, Any], Field(description="{test: ljung-box, lags, statistic, p_value, white, bound, outside_bound}")
    ]
    residual_autocorrelation: Annotated[list[float | None], Field(description="ρ_k of the residual, k = 1..lags")]
    samples: int
    evaluations: int
    starts: int


class ParameterOut(Answer):
    value: Annotated[float, Field(description="estimate [kg, N·s/m, N/m, s or N]")]
    std_error: Annotated[float | None, Field(description="linearised standard error (same unit)")]
    interval: Annotated[list[float | None], Field(description="[lo, hi] at the requested confidence (same unit)")]


class RangeOut(Answer):
    min: float
    max: float


class IdentifyResponse(Answer):
    status: Literal["identified", "identified_with_warnings", "failed"]
    model: Literal["rigid", "cable"] | None
    reason: str
    device: Annotated[dict[str, Any] | None, Field(description="a device object every endpoint accepts")] = None
    parameters: dict[str, ParameterOut] = Field(default_factory=dict)
    uncertainty: Annotated[
        dict[str, RangeOut],
        Field(default_factory=dict, description="device.<name> → {min, max}: ready for requirements.uncertainty"),
    ]
    fit: FitOut | None = None
    comparison: list[ComparisonOut] = Field(default_factory=list)
    warnings: list[str] = Field(default_factory=list)
    confidence: float
    elapsed_ms: float
