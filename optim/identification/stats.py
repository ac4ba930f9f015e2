"""Statistics of a fit: linearised intervals, fit quality, residual whiteness, information criteria.

Intervals: cov = s²·(JᵀJ)⁻¹ with s² = RSS/(n − p) (n real residuals, p fitted numbers), value ±
t_{n−p}((1 + c)/2)·√cov_ii.  They hold when the noise is white and the model right; the Monte Carlo
of bench/bench_identification_coverage.py measures how often they hold the truth
(docs/identification_coverage.md).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.stats import chi2
from scipy.stats import t as student_t

__all__ = [
    "IDENTIFIABLE_RCOND",
    "autocorrelation",
    "covariance",
    "information_criteria",
    "ljung_box",
    "nrmse",
    "quantile",
]

#: a scaled Jacobian whose smallest singular value is below this fraction of the largest has a direction
#: the data do not determine: the fit answers ``failed`` instead of an interval of ±∞
IDENTIFIABLE_RCOND = 1e-9


def covariance(jac: np.ndarray, rss: float) -> tuple[np.ndarray, float, float]:
    """(covariance, s², rcond of the column-scaled Jacobian)."""
    n, p = jac.shape
    norms = np.linalg.norm(jac, axis=0)
    norms = np.where(norms > 0, norms, 1.0)
    js = jac / norms
    _, sv, vt = np.linalg.svd(js, full_matrices=False)
    rcond = float(sv[-1] / sv[0]) if sv[0] > 0 else 0.0
    s2 = rss / max(n - p, 1)
    inv = (vt.T / np.maximum(sv, 1e-300) ** 2) @ vt
    cov = inv / np.outer(norms, norms) * s2
    return cov, s2, rcond


def quantile(confidence: float, dof: int) -> float:
    return float(student_t.ppf(0.5 + confidence / 2, max(dof, 1)))


def nrmse(residual: np.ndarray, measured: np.ndarray) -> float:
    """‖r‖ / ‖y − ȳ‖: 0 is a perfect fit, 1 no better than the mean."""
    den = float(np.linalg.norm(measured - np.mean(measured)))
    return float(np.linalg.norm(residual)) / den if den > 0 else math.inf


def autocorrelation(residual: np.ndarray, lags: int) -> np.ndarray:
    """ρ_k, k = 1..lags, of the residual (mean removed), via FFT."""
    r = np.asarray(residual, float) - np.mean(residual)
    n = len(r)
    size = 1 << (2 * n - 1).bit_length()
    f = np.fft.rfft(r, size)
    ac = np.fft.irfft(f * np.conj(f), size)[:lags + 1]
    return ac[1:] / ac[0] if ac[0] > 0 else np.zeros(lags)


def ljung_box(residual: np.ndarray, lags: int, fitted: int = 0) -> tuple[float, float, np.ndarray]:
    """(Q, p-value, ρ): Q = N(N+2)·Σ ρ_k²/(N−k), χ² with lags − fitted degrees of freedom."""
    n = len(residual)
    rho = autocorrelation(residual, lags)
    k = np.arange(1, lags + 1)
    q = float(n * (n + 2) * np.sum(rho ** 2 / (n - k)))
    dof = max(lags - fitted, 1)
    return q, float(chi2.sf(q, dof)), rho


def information_criteria(rss: float, n: int, p: int) -> tuple[float, float]:
    """(AIC, BIC) of a Gaussian least-squares fit: n·ln(RSS/n) + 2p, n·ln(RSS/n) + p·ln n."""
    base = n * math.log(max(rss, 1e-300) / n)
    return base + 2 * p, base + p * math.log(n)
