"""What a trajectory did: stable, unstable or a limit cycle, and the energy the wall generated.

Verdict (from the settled second half of a run, never from the model): the
sample-to-sample increments of the motor position (they remove any static
offset such as a constant push) are cut into chunks of at least two oscillation
periods; a least-squares line through log(chunk peak) gives the growth rate γ
[1/s], and ρ = e^{γW} is the amplitude ratio over the analysed window W.

  * linear scenes: γ > 0 with ρ > 1 + LINEAR_TOL is ``unstable``, else ``stable``
    (a linear loop has no limit cycle; within the tolerance it is marginal and
    the reason says so);
  * nonlinear scenes: ρ < 1 - NONLINEAR_TOL ``stable``, ρ > 1 + NONLINEAR_TOL
    ``unstable``, otherwise ``limit_cycle`` (a sustained oscillation).

Passivity observer: the exact work of the motor force on the motor mass,
W = Σ u·Δx_r over the held pieces of every period (the force is piecewise
constant, so this is exact), minus what an ideal spring K would have released,
E_gen(t) = W(t) - ½K(x_r(0)² - x_r(t)²).  A passive wall keeps E_gen ≤ 0 (up to
the energy of its damper); a growing E_gen is energy the sampled wall creates.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .sim_loop import Record

__all__ = ["Verdict", "analyse_oscillation", "energy_generated", "LINEAR_TOL", "NONLINEAR_TOL"]

LINEAR_TOL = 1e-3
NONLINEAR_TOL = 0.1


@dataclass(frozen=True)
class Verdict:
    state: str
    """``stable``, ``unstable`` or ``limit_cycle``."""
    frequency: float | None
    """ω [rad/s] of the dominant oscillation in the analysed window (None when at rest)."""
    amplitude: float
    """[m] half the peak-to-peak motor position over the last chunk."""
    growth_rate: float | None
    """γ [1/s] of the oscillation envelope (None when at rest or too short to say)."""
    reason: str


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


def analyse_oscillation(xr: np.ndarray, sample_time: float, linear: bool, diverged: bool) -> Verdict:
    """Verdict from the motor position samples x_r[0..n]."""
    n = len(xr) - 1
    if diverged:
        return Verdict("unstable", None, float(np.max(np.abs(xr))), None,
                       "the motion grew past 1e6 times the largest free motion of the run; the run stopped there")
    if n < 8:
        return Verdict("stable" if linear else "limit_cycle", None, 0.0, None, "run too short to judge")
    window = xr[n // 2:]
    v = np.diff(window)
    scale = max(np.max(np.abs(xr)), 1e-300)
    if np.max(np.abs(v)) <= 1e-13 * scale:
        return Verdict("stable", None, 0.0, None, "the device is at rest in the second half of the run")
    omega = _frequency(v, sample_time)
    period = (2 * math.pi / omega / sample_time) if omega else len(v)
    chunk = int(max(2 * period, len(v) / 40, 4))
    m = len(v) // chunk
    amp_last = 0.5 * float(np.ptp(window[-chunk:]))
    if m < 3:
        return Verdict("stable" if linear else "limit_cycle", omega, amp_last, None,
                       "fewer than three oscillation chunks in the settled half; growth not measured")
    peaks = np.abs(v[:m * chunk]).reshape(m, chunk).max(axis=1)
    if peaks[-1] == 0.0:
        return Verdict("stable", omega, amp_last, None, "the oscillation stopped (the device stuck)")
    good = peaks > 0
    centers = (np.arange(m) + 0.5) * chunk * sample_time
    gamma = float(np.polyfit(centers[good], np.log(peaks[good]), 1)[0])
    span = (m - 1) * chunk * sample_time
    rho = math.exp(max(min(gamma * span, 700.0), -700.0))
    if linear:
        if rho > 1 + LINEAR_TOL:
            return Verdict("unstable", omega, amp_last, gamma, f"the envelope grows by {rho:.4g}× over the settled half")
        note = "marginal: " if rho >= 1 - LINEAR_TOL else ""
        return Verdict("stable", omega, amp_last, gamma, f"{note}the envelope changes by {rho:.4g}× over the "
                                                          "settled half")
    if rho < 1 - NONLINEAR_TOL:
        return Verdict("stable", omega, amp_last, gamma, f"the envelope decays by {rho:.4g}× over the settled half")
    if rho > 1 + NONLINEAR_TOL:
        return Verdict("unstable", omega, amp_last, gamma, f"the envelope grows by {rho:.4g}× over the settled half")
    return Verdict("limit_cycle", omega, amp_last, gamma,
                   f"a sustained oscillation: the envelope changes by {rho:.4g}× over the settled half")


def energy_generated(rec: Record, stiffness: float) -> np.ndarray:
    """E_gen at k = 0..n [J] (module docstring)."""
    xr = rec.motor_position
    n = len(rec.command)
    work = rec.applied_first * (rec.motor_position_mid - xr[:n]) + rec.applied_second * (xr[1:n + 1] - rec.motor_position_mid)
    w = np.concatenate([[0.0], np.cumsum(work)])
    return w - 0.5 * stiffness * (xr[0] ** 2 - xr[:n + 1] ** 2)
