"""Digital low-pass filters of the force-feedforward loop (chapter §5.2, Fig. 24).

D(z) is an analog Butterworth low-pass of order 1-4 mapped to z by the bilinear
transform prewarped at its cutoff, so |D(e^{jω_c T})| = 1/√2 exactly.

On the unit circle the prewarped bilinear map is s = (2/T)·j·tan(θ/2) and the
prewarped analog cutoff is (2/T)·tan(θ_c/2), so

    D(e^{jθ}) = 1 / P_n(j·tan(θ/2) / tan(θ_c/2)),

with P_n the normalised Butterworth polynomial (cutoff 1 rad/s).  That closed
form is what the analysis evaluates (cheap, exact, and writable in CasADi);
``state_space()`` builds the same filter with scipy.signal.butter(..., fs=1/T)
for simulation and for the independent closed-loop test.  D(-1) = 0 exactly
(the bilinear transform maps s = ∞ to z = -1): ``response(π)`` returns 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy import signal

from models.errors import InputError

__all__ = ["MAX_FILTER_ORDER", "ButterworthLowPass", "butterworth_polynomial", "butterworth_response",
           "butterworth_denominator"]

MAX_FILTER_ORDER = 4


@lru_cache(maxsize=None)
def butterworth_polynomial(order: int) -> tuple[float, ...]:
    """Coefficients of the normalised Butterworth polynomial P_n(s), highest power first.

    From its poles s_k = exp(jπ(2k + n - 1)/(2n)), k = 1..n, on the left half unit circle.
    """
    if not 1 <= order <= MAX_FILTER_ORDER:
        raise InputError("order", f"a Butterworth filter of order 1-{MAX_FILTER_ORDER} is supported, got {order}")
    k = np.arange(1, order + 1)
    poles = np.exp(1j * np.pi * (2 * k + order - 1) / (2 * order))
    return tuple(float(c) for c in np.real(np.poly(poles)))


def _half_angle(theta: np.ndarray, cutoff_angle: float) -> np.ndarray:
    """φ = atan(ν) ∈ [0, π/2], ν = tan(θ/2)/tan(θ_c/2), without forming tan(θ/2) (it is ∞ at π)."""
    return np.arctan2(np.sin(0.5 * theta), math.tan(0.5 * cutoff_angle) * np.cos(0.5 * theta))


def butterworth_denominator(theta: np.ndarray, cutoff_angle: float, order: int) -> tuple[np.ndarray, np.ndarray]:
    """(cosⁿφ, Q) with D(e^{jθ}) = cosⁿφ / Q and Q = cosⁿφ·P_n(j·tan φ).

    Q = Σ a_k (j sin φ)^k cos^{n-k} φ is finite and never 0 on [0, π] (at θ = π it
    is jⁿ), so -conj(G_1)·Q has the phase of -1/(D·G_1) even where D vanishes.
    """
    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    phi = _half_angle(theta, cutoff_angle)
    js, c = 1j * np.sin(phi), np.cos(phi)
    q = np.zeros(theta.shape, dtype=complex)
    for k, a in enumerate(butterworth_polynomial(order)):       # a_k for s^(n-k)
        q = q + a * js ** (order - k) * c ** k
    return c ** order, q


def butterworth_response(theta: np.ndarray, cutoff_angle: float, order: int) -> np.ndarray:
    """D(e^{jθ}) of the prewarped bilinear Butterworth with cutoff θ_c [rad/sample], θ in [0, π]."""
    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    cn, q = butterworth_denominator(theta, cutoff_angle, order)
    # cos(π/2) rounds to 6e-17, not 0; D(-1) is exactly 0 (s = ∞ maps to z = -1).
    return np.where(theta >= math.pi, 0.0, cn) / q


@dataclass(frozen=True)
class ButterworthLowPass:
    """Butterworth low-pass D(z), bilinear transform prewarped at the cutoff."""

    order: int
    """n, 1-4."""
    cutoff_hz: float
    """f_c [Hz], strictly between 0 and the Nyquist frequency 1/(2T)."""
    sample_time: float
    """T [s]."""

    def __post_init__(self) -> None:
        butterworth_polynomial(self.order)  # validates the order
        nyquist = 0.5 / self.sample_time
        if not (math.isfinite(self.cutoff_hz) and 0.0 < self.cutoff_hz < nyquist):
            raise InputError("cutoff_hz", f"must be > 0 and below the Nyquist frequency {nyquist:g} Hz, "
                             f"got {self.cutoff_hz:g}")

    @property
    def cutoff_angle(self) -> float:
        """θ_c = 2π f_c T [rad per sample]."""
        return 2.0 * math.pi * self.cutoff_hz * self.sample_time

    def response(self, theta: np.ndarray) -> np.ndarray:
        """D(e^{jθ}) for θ in [0, π] (vectorised)."""
        return butterworth_response(theta, self.cutoff_angle, self.order)

    def zpk(self) -> tuple[np.ndarray, np.ndarray, float]:
        """(zeros, poles, gain) of D(z) from scipy's prewarped bilinear design."""
        z, p, k = signal.butter(self.order, self.cutoff_hz, btype="low", analog=False, output="zpk",
                                fs=1.0 / self.sample_time)
        return np.asarray(z), np.asarray(p), float(k)

    def state_space(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """(A_f, B_f, C_f, D_f) of D(z): w[k+1] = A_f w + B_f y, v = C_f w + D_f y."""
        z, p, k = self.zpk()
        a, b, c, d = signal.zpk2ss(z, p, k)
        return np.asarray(a, float), np.asarray(b, float).ravel(), np.asarray(c, float).ravel(), float(np.squeeze(d))
