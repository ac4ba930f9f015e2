"""The measurements a lab sends, and the rules that make them usable (each error names the field).

Two kinds: a time series (commanded force held by the ZOH and the encoder position, one per sample,
from rest) and a frequency response X/F.  Errors are ValueError("data.<field>: rule") for the
service's 422.  Soft problems (clipping, saturation) are warnings, returned by :func:`warnings_for`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.signal import welch

from optim.domain import check_sample_time, check_signal_scale
from optim.errors import InputError

__all__ = [
    "BAND_RATIO",
    "MAX_RESPONSE_POINTS",
    "MAX_SAMPLES",
    "POINTS_PER_PARAMETER",
    "SAMPLES_PER_PARAMETER",
    "FrequencyResponseData",
    "TimeSeriesData",
    "check_response",
    "check_time_series",
    "excited_band",
    "warnings_for",
]

#: Longest time series [samples]; the fit costs O(N) per model evaluation (docs/bench_identification.md).
MAX_SAMPLES = 200_000
MAX_RESPONSE_POINTS = 20_000
#: a time series needs at least this many samples per free parameter
SAMPLES_PER_PARAMETER = 10
#: a frequency response needs at least this many points per free parameter (each point is 2 real numbers)
POINTS_PER_PARAMETER = 2
#: the smallest ratio f95/f5 of the band holding 5-95 % of the input's power, per model: the rigid
#: model (m, b, t_d) needs two distinct frequencies, the cable model's resonance and anti-resonance
#: a band of at least a decade around them
BAND_RATIO = {"rigid": 1.5, "cable": 10.0}


@dataclass(frozen=True)
class TimeSeriesData:
    """An experiment sampled at the loop's rate, starting at rest (force 0 before the first sample)."""

    sample_time: float
    """T [s]."""
    force: np.ndarray
    """commanded motor force u[k] [N], held over [kT, (k+1)T) by the ZOH (before the loop delay)."""
    position: np.ndarray
    """encoder position x[k] [m] at kT (the motor side of a cable device); any constant offset."""
    kind: Literal["time_series"] = "time_series"


@dataclass(frozen=True)
class FrequencyResponseData:
    """A measured response X/F [m/N] at the encoder, delay included."""

    frequency: np.ndarray
    """ω [rad/s], > 0."""
    response: np.ndarray
    """complex X/F [m/N]."""
    sample_time: float
    """the device's T [s] (the identified device carries it; the ``sampled`` kind uses it in the model)."""
    model_kind: Literal["continuous", "sampled"] = "continuous"
    """continuous: X/F(jω)·e^{−jωt_d} of the mechanics; sampled: the loop's G(e^{jωT}), ZOH included."""
    kind: Literal["frequency_response"] = "frequency_response"


def _finite(name: str, values: np.ndarray) -> None:
    bad = ~np.isfinite(values)
    if bad.any():
        raise InputError(f"data.{name}", f"every value must be finite (index {int(np.argmax(bad))} is not)")


def excited_band(force: np.ndarray, sample_time: float) -> tuple[float, float]:
    """(f5, f95) [Hz]: the band holding 5-95 % of the input's power (its mean removed; Welch, Hann)."""
    u = np.asarray(force, float) - np.mean(force)
    nper = int(min(len(u), 1024))
    f, p = welch(u, fs=1.0 / sample_time, nperseg=nper, detrend=False)
    p = p[1:]
    f = f[1:]
    c = np.cumsum(p)
    if c[-1] <= 0:
        return 0.0, 0.0
    c /= c[-1]
    return float(f[np.searchsorted(c, 0.05)]), float(f[min(np.searchsorted(c, 0.95), len(f) - 1)])


def check_time_series(data: TimeSeriesData, free_parameters: int, models: tuple[str, ...]) -> None:
    """Raise ValueError("data.<field>: rule") when the record cannot identify ``models``."""
    if not (math.isfinite(data.sample_time) and 0 < data.sample_time <= 1.0):
        raise InputError("data.sample_time", "must be finite, > 0 and ≤ 1 s")
    check_sample_time(data.sample_time, "data.sample_time")
    u, y = data.force, data.position
    if u.ndim != 1 or y.ndim != 1:
        raise InputError("data.force", "force and position must be flat lists of numbers")
    if len(u) != len(y):
        raise InputError("data.position", f"must have as many values as data.force ({len(y)} ≠ {len(u)})")
    if len(u) > MAX_SAMPLES:
        raise InputError("data.force", f"at most {MAX_SAMPLES} samples, got {len(u)}")
    _finite("force", u)
    _finite("position", y)
    need = SAMPLES_PER_PARAMETER * free_parameters
    if len(u) < need:
        raise InputError("data.force", f"{len(u)} samples are too few for {free_parameters} free parameters "
                         f"(at least {SAMPLES_PER_PARAMETER} per parameter: {need})")
    scale = float(np.max(np.abs(u)))
    if scale == 0.0 or float(np.ptp(u)) <= 1e-12 * scale:
        raise InputError("data.force", "the input is constant, it excites nothing (use a chirp, a PRBS or steps)")
    if float(np.ptp(y)) == 0.0:
        raise InputError("data.position", "the position never changes (no motion was measured)")
    check_signal_scale(scale, "data.force", "the largest |force|")
    check_signal_scale(float(np.ptp(y)), "data.position", "the position's range (max − min)")
    f5, f95 = excited_band(u, data.sample_time)
    for m in models:
        ratio = f95 / f5 if f5 > 0 else math.inf
        if ratio < BAND_RATIO[m]:
            raise InputError(
                "data.force", f"too narrow a band for the {m} model: 90 % of the input's power lies within "
                f"{f5:.4g}-{f95:.4g} Hz (ratio {ratio:.3g}); the {m} model needs a ratio of at least "
                f"{BAND_RATIO[m]:g} (a chirp or a PRBS over the band of interest)")


def check_response(data: FrequencyResponseData, free_parameters: int) -> None:
    w, h = data.frequency, data.response
    if not (math.isfinite(data.sample_time) and 0 < data.sample_time <= 1.0):
        raise InputError("sample_time", "must be finite, > 0 and ≤ 1 s")
    check_sample_time(data.sample_time, "sample_time")
    if len(w) != len(h):
        raise InputError("data.real", f"frequency, real and imag must have the same length ({len(w)} ≠ {len(h)})")
    if len(w) > MAX_RESPONSE_POINTS:
        raise InputError("data.frequency", f"at most {MAX_RESPONSE_POINTS} points, got {len(w)}")
    _finite("frequency", w)
    _finite("real", h.real)
    _finite("imag", h.imag)
    need = POINTS_PER_PARAMETER * free_parameters
    if len(w) < need:
        raise InputError("data.frequency", f"{len(w)} points are too few for {free_parameters} free parameters "
                         f"(at least {POINTS_PER_PARAMETER} per parameter: {need})")
    if np.any(w <= 0):
        raise InputError("data.frequency", "every frequency must be > 0 rad/s")
    if len(np.unique(w)) < need:
        raise InputError("data.frequency", f"{len(np.unique(w))} distinct frequencies are too few for "
                         f"{free_parameters} free parameters (at least {need})")
    if np.any(np.abs(h) == 0):
        raise InputError("data.real", "a response of exactly 0 cannot be weighted (relative error)")
    check_signal_scale(float(np.min(np.abs(h))), "data.real", "the smallest |X/F|")
    if data.model_kind == "sampled" and np.any(w * data.sample_time >= math.pi):
        raise InputError("data.frequency", f"a sampled response is defined below the Nyquist frequency "
                         f"π/T = {math.pi / data.sample_time:.6g} rad/s")


def _clipped(name: str, v: np.ndarray) -> list[str]:
    """A signal with many distinct values but a share of samples exactly at its max or min: clipped."""
    out: list[str] = []
    if len(np.unique(v)) <= 10:                 # a PRBS or steps: sitting at the extremes is its design
        return out
    for label, ext in (("maximum", np.max(v)), ("minimum", np.min(v))):
        at = int(np.sum(v == ext))
        if at >= max(5, len(v) // 200):
            out.append(f"data.{name}: {at} samples sit exactly at the {label} {ext:.6g} — clipped or "
                       f"saturated data biases the fit (the model is linear); remove those stretches")
    return out


def warnings_for(data: TimeSeriesData | FrequencyResponseData) -> list[str]:
    if isinstance(data, FrequencyResponseData):
        return []
    return _clipped("force", data.force) + _clipped("position", data.position)
