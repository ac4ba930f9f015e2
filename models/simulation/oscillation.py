"""What a trajectory did, measured from the trajectory alone, and the energy the wall generated.

The measured verdict never claims more than the record shows.  It reads the
sample-to-sample increments v of the motor position (they remove any static
offset such as a constant push) cut into chunks of at least two periods of the
dominant oscillation (FFT of the settled second half), with the chunk peaks P_j:

  * ``unstable``: the run diverged, or growth is measured: the settled half holds
    ≥ MIN_CHUNKS chunks, each of its last GROWING_CHUNKS chunks is larger than the
    one before, the last is the largest of the settled half, and the envelope
    grows by more than 1 + GROWTH_TOL over it (least squares through log P_j);
    or one spectral line grows on its own (``_growing_mode``: the mode may hide
    under a larger decaying transient);
    Neither claim is made while the settled half is dominated by a motion it does
    not resolve (its best quadratic varies more than the rest): a fraction of a slow
    period looks like growth or decay, and its leakage like a growing line;
  * ``stable``: decay of every mode the record shows is shown: the motion stopped
    exactly (a stuck device), or the last chunk is below REST_FRACTION of the
    run's largest increment (a growing mode excited at more than that fraction of
    the motion would still be visible);
  * ``limit_cycle`` (nonlinear scenes only): a sustained oscillation, the envelope
    within ±NONLINEAR_TOL over the settled half;
  * ``undetermined`` otherwise, with the reason and, when a trend is measured, the
    duration after which the same trend would decide (``decisive_duration``).

A decaying envelope is never enough for ``stable``: a slowly growing mode can
hide under a decaying transient (a 793 rad/s cable mode growing 1.00009× per
sample under a slow wall transient, issue 17).  For a linear scene the exact
verdict comes from the closed-loop poles (models/simulation/scene_poles.py); this one is
shown beside it.

Passivity observer: the exact work of the motor force on the motor mass,
W = Σ u·Δx_r over the held pieces of every period (the force is piecewise
constant, so this is exact), minus what an ideal spring K would have released,
E_gen(t) = W(t) - ½K(x_r(0)² - x_r(t)²).  A passive wall keeps E_gen ≤ 0 (up to
the energy of its damper); a growing E_gen is energy the sampled wall creates.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from models.simulation.sim_loop import Record

__all__ = ["Verdict", "VerdictState", "analyse_oscillation", "energy_generated", "GROWTH_TOL", "NONLINEAR_TOL",
           "REST_FRACTION", "MIN_CHUNKS", "GROWING_CHUNKS", "SPECTRAL_WINDOWS", "LINE_FLOOR"]

VerdictState = Literal["stable", "unstable", "undetermined", "limit_cycle"]

GROWTH_TOL = 0.05
NONLINEAR_TOL = 0.1
REST_FRACTION = 1e-8
MIN_CHUNKS = 6
GROWING_CHUNKS = 4
SPECTRAL_WINDOWS = 8
LINE_FLOOR = 1e-6
MIN_LINE_BIN = 3
PROMINENCE = 10.0


@dataclass(frozen=True)
class Verdict:
    state: VerdictState
    """``stable``, ``unstable``, ``undetermined`` or ``limit_cycle`` (nonlinear scenes)."""
    frequency: float | None
    """ω [rad/s] of the dominant oscillation in the analysed window (None when at rest)."""
    amplitude: float
    """[m] half the peak-to-peak motor position over the last chunk."""
    growth_rate: float | None
    """γ [1/s] of the oscillation envelope (None when at rest or too short to say)."""
    reason: str
    decisive_duration: float | None = None
    """[s] a run this long would decide, extrapolating the measured trend (undetermined only; None when
    no trend is measured)."""


def _frequency(v: np.ndarray, t: float) -> float | None:
    x = v - v.mean()
    if not np.any(x):
        return None
    n = len(x)
    nfft = 1 << int(math.ceil(math.log2(4 * n)))
    spec = np.abs(np.fft.rfft(x * np.hanning(n), nfft))
    i = int(np.argmax(spec[1:])) + 1
    shift = 0.0
    if 1 <= i < len(spec) - 1 and spec[i - 1] > 0 and spec[i + 1] > 0:
        a, b, c = np.log(spec[i - 1]), np.log(spec[i]), np.log(spec[i + 1])
        den = a - 2 * b + c
        shift = 0.5 * (a - c) / den if den != 0 else 0.0
    return 2 * math.pi * (i + shift) / (nfft * t)


def _slow_and_fast(window: np.ndarray) -> tuple[float, float]:
    """[m] peak-to-peak of the best quadratic through the settled positions (a motion slower than the window:
    a fraction of a period, or a slow approach to an offset) and of what is left (the oscillation)."""
    s = np.linspace(-1.0, 1.0, len(window))
    basis = np.vander(s, 3)
    trend = basis @ np.linalg.lstsq(basis, window, rcond=None)[0]
    return float(np.ptp(trend - trend.mean()) if len(trend) else 0.0), float(np.ptp(window - trend))


def _growing_mode(v: np.ndarray, t: float) -> tuple[float, float] | None:
    """(ω [rad/s], growth over the window) of the strongest spectral line that grows on its own, or None.

    The settled increments are cut into SPECTRAL_WINDOWS windows; in each, the Hann-windowed amplitude of
    every frequency bin (after removing a quadratic trend).  A line (≥ MIN_LINE_BIN periods per window)
    grows when it is a local peak of the last window, PROMINENCE× above the bins 3 away and above LINE_FLOOR of the
    largest amplitude, rises over each of the last GROWING_CHUNKS windows, is largest in the last one, and
    its least-squares log-slope over all windows gives more than 1 + GROWTH_TOL.  A decaying mode decays
    in every bin, so a fast mode growing under a slow decaying transient is seen here.
    """
    length = len(v) // SPECTRAL_WINDOWS
    if length < 16:
        return None
    frames = v[:SPECTRAL_WINDOWS * length].reshape(SPECTRAL_WINDOWS, length)
    # A motion slower than the window (a fraction of a period) is not a line but leaks into every bin
    # with its own phase-driven trend: remove a quadratic per window first.
    basis = np.vander(np.linspace(-1.0, 1.0, length), 3)
    frames = frames - (basis @ np.linalg.lstsq(basis, frames.T, rcond=None)[0]).T
    amp = np.abs(np.fft.rfft(frames * np.hanning(length), axis=1))
    top = float(amp.max())
    if top == 0.0:
        return None
    last = amp[-1]
    peak = np.zeros_like(last, dtype=bool)
    peak[1:-1] = (last[1:-1] >= last[:-2]) & (last[1:-1] >= last[2:])
    peak[:MIN_LINE_BIN] = False                 # at least MIN_LINE_BIN periods per window
    # a line stands PROMINENCE× above the bins 3 away (Hann: main lobe ±2 bins, side lobes < -31 dB);
    # leakage of a motion the window does not resolve is broad and does not
    side = np.full_like(last, np.inf)
    side[3:-3] = np.maximum(last[:-6], last[6:])
    peak &= last >= PROMINENCE * side
    cand = peak & (last >= LINE_FLOOR * top) & (last >= amp.max(axis=0))
    cand &= np.all(np.diff(amp[-GROWING_CHUNKS - 1:], axis=0) > 0, axis=0)
    if not cand.any():
        return None
    idx = np.flatnonzero(cand)
    x = np.arange(SPECTRAL_WINDOWS) * length * t
    slopes = np.polyfit(x, np.log(np.maximum(amp[:, idx], 1e-300)), 1)[0]
    growth = np.exp(np.minimum(slopes * x[-1], 700.0))
    ok = growth > 1 + GROWTH_TOL
    if not ok.any():
        return None
    best = int(np.argmax(np.where(ok, last[idx], -np.inf)))
    return 2 * math.pi * idx[best] / (length * t), float(growth[best])


def _undetermined(omega, amp, gamma, why: str, duration: float | None) -> Verdict:
    tail = f"; a run of about {duration:.3g} s would decide" if duration is not None else ""
    return Verdict("undetermined", omega, amp, gamma, why + tail, duration)


def analyse_oscillation(xr: np.ndarray, sample_time: float, linear: bool, diverged: bool) -> Verdict:
    """Measured verdict from the motor position samples x_r[0..n] (module docstring)."""
    n = len(xr) - 1
    t = sample_time
    if diverged:
        return Verdict("unstable", None, float(np.max(np.abs(xr))), None,
                       "the motion grew past 1e6 times the largest free motion of the run; the run stopped there")
    v_all = np.diff(xr)
    if n < 8 or not np.any(v_all):
        why = "the run is too short to judge" if n < 8 else "the device never moved: the scene excites no mode"
        return _undetermined(None, 0.0, None, why, None)
    peak = float(np.max(np.abs(v_all)))
    window = xr[n // 2:]
    v = np.diff(window)
    if not np.any(v):
        what = "decayed to exactly zero" if linear else "stopped exactly (stuck, or at rest inside a dead band)"
        return Verdict("stable", None, 0.0, None, f"the motion {what} in the settled half")
    omega = _frequency(v, t)
    period = (2 * math.pi / omega / t) if omega else len(v)
    chunk = int(max(2 * period, len(v) / 40, 4))
    m = len(v) // chunk
    amp_last = 0.5 * float(np.ptp(window[-chunk:]))
    last = float(np.max(np.abs(v[-chunk:])))
    if last <= REST_FRACTION * peak:
        return Verdict("stable", omega, amp_last, None,
                       f"the motion decayed to {last / peak:.2g} of its largest step (below {REST_FRACTION:g}): "
                       "every mode the record shows decays")
    slow, fast = _slow_and_fast(window)
    if slow > fast:
        need = 2 * n * t * max(2.0, math.sqrt(slow / max(fast, 1e-300)))
        return _undetermined(omega, amp_last, None, f"the settled half is dominated by a motion slower than it "
                             f"resolves (a quadratic trend of {slow:.3g} m against {fast:.3g} m of oscillation); "
                             "growth or decay not measured", need)
    line = _growing_mode(v, t)
    if line is not None:
        return Verdict("unstable", line[0], amp_last, math.log(line[1]) / (len(v) * t),
                       f"a spectral line at {line[0]:.4g} rad/s grows by {line[1]:.4g}× over the settled half "
                       f"and rises over its last {GROWING_CHUNKS} windows")
    if m < MIN_CHUNKS:
        need = 2 * MIN_CHUNKS * chunk * t
        return _undetermined(omega, amp_last, None, f"the settled half holds {m} oscillation chunks of "
                             f"{chunk} samples, fewer than {MIN_CHUNKS}; growth or decay not measured",
                             max(need, 2 * n * t))
    peaks = np.abs(v[:m * chunk]).reshape(m, chunk).max(axis=1)
    good = peaks > 0
    centers = (np.arange(m) + 0.5) * chunk * t
    gamma = float(np.polyfit(centers[good], np.log(peaks[good]), 1)[0]) if good.sum() >= 2 else 0.0
    span = (m - 1) * chunk * t
    rho = math.exp(max(min(gamma * span, 700.0), -700.0))
    tail = peaks[-GROWING_CHUNKS - 1:]
    growing = bool(np.all(np.diff(tail) > 0)) and peaks[-1] >= peaks.max()
    if growing and rho > 1 + GROWTH_TOL:
        return Verdict("unstable", omega, amp_last, gamma,
                       f"the envelope grows by {rho:.4g}× over the settled half and rises over its last "
                       f"{GROWING_CHUNKS} chunks")
    if not linear and abs(rho - 1) <= NONLINEAR_TOL:
        return Verdict("limit_cycle", omega, amp_last, gamma,
                       f"a sustained oscillation: the envelope changes by {rho:.4g}× over the settled half")
    duration = None
    if gamma < 0 and rho < 1 - GROWTH_TOL:
        duration = n * t + math.log(REST_FRACTION * peak / last) / gamma
        why = (f"the envelope decays by {rho:.4g}× over the settled half but is still {last / peak:.2g} of its "
               f"largest step (stable needs below {REST_FRACTION:g}: a slower growing mode could hide under it)")
    elif gamma > 0 and rho > 1 + GROWTH_TOL:
        duration = 2 * n * t
        why = f"the envelope grows by {rho:.4g}× over the settled half but does not rise steadily at its end"
    else:
        if gamma > 0:
            duration = 2 * max(n * t / 2, math.log(1 + 2 * GROWTH_TOL) / gamma)
        why = f"the envelope changes by {rho:.4g}× over the settled half: no growth or decay measured"
    return _undetermined(omega, amp_last, gamma, why, duration)


def energy_generated(rec: Record, stiffness: float) -> np.ndarray:
    """E_gen at k = 0..n [J] (module docstring)."""
    xr = rec.motor_position
    n = len(rec.command)
    work = rec.applied_first * (rec.motor_position_mid - xr[:n]) + rec.applied_second * (xr[1:n + 1] - rec.motor_position_mid)
    w = np.concatenate([[0.0], np.cumsum(work)])
    return w - 0.5 * stiffness * (xr[0] ** 2 - xr[:n + 1] ** 2)
