"""What encoder quantisation does to the damper force through the velocity estimate (ARCHITECTURE.md, "The rendered
virtual environment", the noise rules).

With V(z) = (1 − w)·R(w)/(T·D(w)), w = z⁻¹ (models.velocity_filter):

* s_k, V's response to a unit position step, is the impulse response of R/D divided by T: one encoder count q
  makes the damper force jump by at most B·q·max_k |s_k| (``step_peak``; 1/T for the backward difference, today's
  ``quantization``/``max_force_noise`` rule B·q/T ≤ F_noise);
* h_k, V's impulse response: white quantisation noise of variance q²/12 gives a damper force noise of
  B·q·sqrt(Σ h_k²/12) rms (``noise_gain`` = sqrt(Σ h_k²); √2/T for the backward difference).

Σ h_k² comes from the discrete Lyapunov equation of the filter's state-space form when its slowest pole lies
within |z| ≤ 0.99 (exact, no truncated sum); closer to the circle that equation is ill-conditioned (the filter's
unit DC gain against the difference's zero at z = 1: rcond 1e-18 at ν = fT = 1e-5), and Parseval's integral
(1/π)∫₀^π |T·V(e^{jθ})|² dθ is taken instead, in ln θ with the filter's pole angles and bandwidth as breakpoints
(scipy's adaptive quadrature to 1e-11 relative).  max |s_k| runs the step response until the slowest mode has
decayed below 1e-17 of the peak (at most MAX_STEP_SAMPLES: the peak comes long before).  For the first-order low-pass (a = exp(−2π f T)) they are (1 − a)/T and ((1 − a)/T)·sqrt(2/(1 + a)).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import integrate, linalg, signal

from models.velocity_filter import VelocityTransfer

__all__ = ["step_peak", "noise_gain", "force_step", "force_noise_rms", "MAX_STEP_SAMPLES"]

#: The step response is run for at most this many samples (a pole at 1 − 1e-9 would need more: refused upstream).
MAX_STEP_SAMPLES = 2_000_000


def _impulse_rd(vt: VelocityTransfer, n: int) -> np.ndarray:
    x = np.zeros(n)
    x[0] = 1.0
    return signal.lfilter(np.asarray(vt.r), np.asarray(vt.d), x)


def _slowest_radius(d: tuple[float, ...]) -> float:
    if len(d) < 2:
        return 0.0
    return float(np.max(np.abs(np.roots(np.asarray(d)))))


def step_peak(vt: VelocityTransfer, sample_time: float) -> float:
    """max_k |s_k| [1/s]: the largest velocity estimate after a one-count position step, per metre of step."""
    if vt.is_backward_difference:
        return 1.0 / sample_time
    if len(vt.d) == 2 and len(vt.r) == 1:            # first order: R/D = r0/(1 − a w), a ∈ [0, 1)
        a = -vt.d[1]
        if 0.0 <= a < 1.0:
            return abs(vt.r[0]) / sample_time
    rho = _slowest_radius(vt.d)
    n = len(vt.r) + 8
    if rho > 0.0:
        n += int(min(MAX_STEP_SAMPLES, math.ceil(math.log(1e-17) / math.log(rho)) if rho < 1.0 else MAX_STEP_SAMPLES))
    return float(np.max(np.abs(_impulse_rd(vt, n)))) / sample_time


def noise_gain(vt: VelocityTransfer, sample_time: float) -> float:
    """sqrt(Σ h_k²) [1/s], h the impulse response of V: the rms velocity estimate per unit white position noise."""
    if vt.is_backward_difference:
        return math.sqrt(2.0) / sample_time
    num = np.convolve([1.0, -1.0], vt.r)                  # T·V = (1 − w)·R/D
    den = np.asarray(vt.d, dtype=float)
    if den.size == 1:
        return float(np.sqrt(np.sum(num * num))) / sample_time
    rho = _slowest_radius(vt.d)
    if rho > 0.99:
        return _parseval(vt) / sample_time
    n = max(num.size, den.size)
    num = np.pad(num, (0, n - num.size))
    den = np.pad(den, (0, n - den.size))
    a, b, c, dd = signal.tf2ss(num, den)
    p = linalg.solve_discrete_lyapunov(a, b @ b.T)
    total = float(dd[0, 0] ** 2 + (c @ p @ c.T)[0, 0])
    return math.sqrt(max(total, 0.0)) / sample_time


def _parseval(vt: VelocityTransfer) -> float:
    """sqrt((1/π)∫₀^π |T·V(e^{jθ})|² dθ), integrated in u = ln θ."""
    roots = np.roots(np.asarray(vt.d)) if len(vt.d) > 1 else np.zeros(0)
    scales = [abs(math.log(abs(z))) for z in roots if 0.0 < abs(z) < 1.0] + list(vt.pole_angles())
    lo = math.log(1e-14)
    points = sorted({math.log(x) for x in scales if 1e-14 < x < math.pi})

    def f(u: float) -> float:
        th = math.exp(u)
        return float(abs(vt.response(np.array([th]))[0]) ** 2) * th
    total, _ = integrate.quad(f, lo, math.log(math.pi), points=points or None, limit=500, epsabs=0.0, epsrel=1e-11)
    return math.sqrt(total / math.pi)


def force_step(damping: float, quantization: float, vt: VelocityTransfer, sample_time: float) -> float:
    """B·q·max|s_k| [N]: the largest damper force step one encoder count makes."""
    return damping * quantization * step_peak(vt, sample_time)


def force_noise_rms(damping: float, quantization: float, vt: VelocityTransfer, sample_time: float) -> float:
    """B·q·sqrt(Σ h_k²/12) [N rms]: the damper force noise of white quantisation noise (variance q²/12)."""
    return damping * quantization * noise_gain(vt, sample_time) / math.sqrt(12.0)
