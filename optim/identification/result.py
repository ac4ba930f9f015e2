"""The typed answer of an identification (SI units)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

__all__ = ["Comparison", "FitQuality", "IdentificationResult", "Parameter"]


@dataclass(frozen=True)
class Parameter:
    value: float
    """estimate [SI unit of the parameter: kg, N·s/m, N/m, s, N]"""
    std_error: float
    """linearised standard error (same unit)"""
    interval: tuple[float, float]
    """confidence interval at the requested level (same unit), clipped at 0 for a quantity ≥ 0"""


@dataclass(frozen=True)
class FitQuality:
    nrmse: float
    """‖residual‖ / ‖measured − mean‖ (time series: position; response: relative complex error)"""
    rmse: float
    """root-mean-square residual [m] (time series) or relative error [-] (response)"""
    residual_whiteness: dict
    """{test: "ljung-box", lags, statistic, p_value, white (p ≥ 0.05), bound (±z/√N), outside_bound}"""
    residual_autocorrelation: tuple[float, ...]
    """ρ_k of the residual, k = 1..lags"""
    samples: int
    """real residuals in the fit (samples; 2 per frequency for a response)"""
    evaluations: int
    """model evaluations the fit used (starts, iterations and Jacobians)"""
    starts: int
    """least-squares runs (the multistart of optim/identification/starts.py)"""


@dataclass(frozen=True)
class Comparison:
    model: Literal["rigid", "cable"]
    aic: float | None
    bic: float | None
    nrmse: float | None
    status: Literal["identified", "failed"]
    reason: str | None = None


@dataclass(frozen=True)
class IdentificationResult:
    status: Literal["identified", "identified_with_warnings", "failed"]
    """identified_with_warnings: a misspecification test fired (optim.identification.misspecification): the
    values are the fit's, the intervals widened, the uncertainty box withdrawn, the warnings say why"""
    model: Literal["rigid", "cable"] | None
    reason: str
    """why this model (auto: the information criteria), or why the fit failed"""
    device: dict | None = None
    """a device object every endpoint accepts (None when failed)"""
    parameters: dict[str, Parameter] = field(default_factory=dict)
    uncertainty: dict[str, dict[str, float]] = field(default_factory=dict)
    """device.<name> → {min, max}: the intervals, ready for requirements.uncertainty"""
    fit: FitQuality | None = None
    comparison: tuple[Comparison, ...] = ()
    warnings: tuple[str, ...] = ()
    confidence: float = 0.95
    fitted: dict | None = None
    """measured and fitted curves for the plot: {x, measured, fitted, kind}"""
    elapsed_ms: float = 0.0
