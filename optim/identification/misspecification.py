"""Is the model wrong for these data?  Tests run after a fit, before its intervals are believed (issue 34).

The linearised intervals (stats.covariance) assume the model is right and the noise white.  Data that the
model cannot explain — a cable device fitted as rigid, a delay held at a wrong value, a force the motor
clipped but the log did not, drifting noise — fit with tight intervals around a wrong value (seen: mass
8.76 [8.65, 8.88] against a true 5.4).  Three tests look for that:

* **whiteness beyond a threshold**: the Ljung–Box statistic of the residual with p below ``WHITENESS_P``
  (1e-6), unless the residual is at the data's rounding level (RMS ≤ ``EXACT_FIT`` of their spread).  The usual 0.05 flags one clean record in twenty (it stays a warning only); at 1e-6 a clean record
  is flagged by chance once in a million, while every misspecified record of the tests has Q in the
  10^4–10^5 (the 20-lag threshold is Q ≈ 68);
* **drift across the record**: the model refitted on the first half of a time series (a record from rest,
  like the whole) must agree with the whole record's fit: |θ_half − θ| ≤ ``DRIFT_Z``·√(se_half² − se²)
  (nested estimators: the variance of the difference is the difference of variances); 5 σ per parameter;
* **a saturated force in the log**: the logged force sits at its extreme value (to 1e-9) in more than
  ``PLATEAU_FRACTION`` of the samples (a clipped command logged after the clip; a clip the log does not
  show is caught by the two tests above).

A flagged fit is ``identified_with_warnings``: its intervals are widened by the residual's long-run variance
factor F = 1 + 2·Σ_k (1 − k/(L+1))·ρ_k (Bartlett weights over the L tested lags; F ≥ 1) and stretched to hold
the half-record estimate, and the ``uncertainty`` box is withdrawn: a misspecified model's intervals are not
an uncertainty a robust design can rely on (a bias is not covered by any width computed from the same fit).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["EXACT_FIT", "WHITENESS_P", "DRIFT_Z", "PLATEAU_FRACTION", "Misspecification", "long_run_factor", "plateau",
           "drift"]

WHITENESS_P = 1e-6
#: a residual whose RMS is below this share of the data's spread is rounding (an exact record): not tested
#: for whiteness nor drift (rounding is not white noise, the standard errors are rounding-sized, and there is
#: no misfit to find)
EXACT_FIT = 1e-9
DRIFT_Z = 5.0
PLATEAU_FRACTION = 0.01


@dataclass(frozen=True)
class Misspecification:
    """The tests' findings: empty ``reasons`` means none fired."""

    reasons: tuple[str, ...]
    variance_factor: float
    """F, the residual's long-run variance over its variance (1 for white noise)."""
    half_values: dict[str, float]
    """the first half's estimates (time series; empty when not refitted)."""

    @property
    def flagged(self) -> bool:
        return bool(self.reasons)


def long_run_factor(rho: np.ndarray) -> float:
    """F = 1 + 2·Σ_{k=1..L} (1 − k/(L+1))·ρ_k, at least 1 (Bartlett / Newey–West weights)."""
    rho = np.asarray(rho, float)
    lags = rho.size
    w = 1.0 - np.arange(1, lags + 1) / (lags + 1)
    return max(1.0, 1.0 + 2.0 * float(np.sum(w * rho)))


#: A force log with at most this many distinct levels (to 1e-9 of its peak) is a multi-level input by design (a
#: PRBS takes ±A, a three-level signal −A, 0, +A): sitting at its extreme is then no sign of saturation.
DESIGNED_LEVELS = 3


def plateau(force: np.ndarray) -> float:
    """Fraction of the samples at the force's extreme magnitude (to 1e-9 relative); 0 for a multi-level input by
    design (≤ DESIGNED_LEVELS distinct levels: a PRBS is at its extreme by construction, not clipped)."""
    f = np.asarray(force, float)
    a = np.abs(f)
    top = float(np.max(a)) if a.size else 0.0
    if not top > 0:
        return 0.0
    if np.unique(np.round(f / (top * 1e-9))).size <= DESIGNED_LEVELS:
        return 0.0
    return float(np.mean(a >= top * (1.0 - 1e-9)))


def drift(names, whole: dict[str, float], whole_se: dict[str, float], half: dict[str, float],
          half_se: dict[str, float]) -> list[str]:
    """The parameters whose half-record estimate leaves the whole record's by more than DRIFT_Z σ."""
    out = []
    for n in names:
        if n not in half or n not in whole:
            continue
        var = half_se[n] ** 2 - whole_se[n] ** 2
        sd = math.sqrt(var) if var > 0 else half_se[n]
        d = abs(half[n] - whole[n])
        if d > DRIFT_Z * sd and d > 1e-9 * max(abs(whole[n]), 1e-300):
            out.append(f"{n} {whole[n]:.6g} on the whole record, {half[n]:.6g} on its first half "
                       f"({d / sd:.3g} σ apart)" if sd > 0 else f"{n} {whole[n]:.6g} against {half[n]:.6g}")
    return out
