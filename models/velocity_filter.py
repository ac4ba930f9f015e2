"""The rendered virtual environment: the velocity the damper sees, and the virtual mass (ARCHITECTURE.md,
"The rendered virtual environment").

The wall a lab renders is C(z) = K + B·V(z) + M·A(z), with V the velocity estimate and A(z) = V(z)·(1 − z⁻¹)/T
the acceleration.  Every kind of V is a ratio of polynomials in w = z⁻¹:

    V(z) = (1 − w)·R(w) / (T·D(w)),   D(0) = 1,

so the zero at z = 1 every velocity estimate has (V(1) = 0) is held exactly, and 1 − e^{−jθ} is evaluated by
expm1 (accurate at the small angles where the stiffness loop's crossovers sit).  R and D are dimensionless;
V'(1)·T = R(1)/D(1) = 1 (a velocity, in m/s per m/s).

| kind | R(w) | D(w) |
|---|---|---|
| backward_difference | 1 | 1 |
| low_pass, order 1 | 1 − a, a = exp(−2π f T) (step-invariant) | 1 − a w |
| low_pass, order 2 | b(w), scipy.signal.butter(2, f, fs=1/T) | a(w) of the same |
| moving_average, n | (1 + w + … + w^{n−1})/n | 1 |
| transfer_function N/D | T·(cumulative sums of N) (N divided by 1 − w) | D/D(0) |
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Annotated, Literal, Union

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator

from models.errors import InputError

__all__ = ["BackwardDifference", "LowPass", "MovingAverage", "TransferFunctionFilter", "VelocityFilter",
           "VelocityTransfer", "Rendering", "velocity_transfer", "rendering", "filter_spec", "DEFAULT_RENDERING",
           "MAX_FILTER_COEFFICIENTS", "MAX_AVERAGE_SAMPLES", "GAIN_RTOL", "POLE_MARGIN", "MAX_VIRTUAL_MASS", "poly_at"]

#: Coefficients of a transfer_function's numerator or denominator, at most.
MAX_FILTER_COEFFICIENTS = 64
#: Samples of a moving average, at most (the closed loop's state grows with it).
MAX_AVERAGE_SAMPLES = 1000
#: A transfer_function is a velocity when |V(1)|·T and |V'(1)·T − 1| are below this (relative).
GAIN_RTOL = 1e-9
#: The denominator's roots must lie inside |z| ≤ 1 − POLE_MARGIN (a pole on the circle is no filter).
POLE_MARGIN = 1e-9
#: |M| at most [kg]: keeps M/m representable beside the device's own bounds.
MAX_VIRTUAL_MASS = 1e12

_SPEC = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True, strict=True)


class BackwardDifference(BaseModel):
    """V(z) = (1 − z⁻¹)/T: today's wall."""

    model_config = _SPEC
    kind: Literal["backward_difference"] = "backward_difference"


class LowPass(BaseModel):
    """The backward difference followed by a low-pass of unit DC gain: order 1 step-invariant
    ((1 − a)/(1 − a z⁻¹), a = exp(−2π f T)), order 2 the Butterworth of scipy.signal.butter(2, f, fs=1/T)."""

    model_config = _SPEC
    kind: Literal["low_pass"]
    cutoff_hz: float = Field(gt=0, le=1e12, description="f, cutoff [Hz]; below the Nyquist frequency 1/(2T)")
    order: Literal[1, 2] = Field(default=1, description="1 (first order) or 2 (Butterworth)")


class MovingAverage(BaseModel):
    """V(z) = (1 − z⁻ⁿ)/(n T): the mean of the last n backward differences."""

    model_config = _SPEC
    kind: Literal["moving_average"]
    samples: int = Field(ge=1, le=MAX_AVERAGE_SAMPLES, description="n, samples averaged")


class TransferFunctionFilter(BaseModel):
    """V(z) = N(z⁻¹)/D(z⁻¹), coefficients in ascending powers of z⁻¹, N in 1/s (m/s per m)."""

    model_config = _SPEC
    kind: Literal["transfer_function"]
    numerator: list[float] = Field(min_length=2, max_length=MAX_FILTER_COEFFICIENTS,
                                         description="N [1/s], ascending powers of z⁻¹; N(1) = 0")
    denominator: list[float] = Field(default_factory=lambda: [1.0], min_length=1, max_length=MAX_FILTER_COEFFICIENTS,
                                           description="D, ascending powers of z⁻¹; D(0) ≠ 0, roots inside |z| < 1")

    @field_validator("numerator", "denominator")
    @classmethod
    def _bounded(cls, v: list[float]) -> list[float]:
        if any(abs(c) > 1e15 for c in v):
            raise ValueError("every coefficient must have |c| ≤ 1e15")
        return v


VelocityFilter = Annotated[Union[BackwardDifference, LowPass, MovingAverage, TransferFunctionFilter],
                           Field(discriminator="kind")]


@dataclass(frozen=True)
class VelocityTransfer:
    """V(z) = (1 − w)·R(w)/(T·D(w)), w = z⁻¹ (module docstring); R, D dimensionless, ascending powers of w."""

    kind: str
    r: tuple[float, ...]
    d: tuple[float, ...]
    """D(w) with D(0) = 1."""

    @property
    def is_backward_difference(self) -> bool:
        return self.r == (1.0,) and self.d == (1.0,)

    def response(self, theta: np.ndarray) -> np.ndarray:
        """T·V(e^{jθ}) (dimensionless)."""
        w = np.exp(-1j * theta)
        return -np.expm1(-1j * theta) * poly_at(self.r, w) / poly_at(self.d, w)

    def acceleration(self, theta: np.ndarray) -> np.ndarray:
        """T²·A(e^{jθ}) = T·V·(1 − e^{−jθ}) (dimensionless)."""
        return self.response(theta) * -np.expm1(-1j * theta)

    def pole_angles(self) -> tuple[float, ...]:
        """Angles in (0, π] of D's roots in z (clusters for the scan where a pole sits near the circle)."""
        return _angles(self.d)

    def zero_angles(self) -> tuple[float, ...]:
        """Angles in (0, π] of R's roots in z (a moving average's lie on the circle)."""
        return _angles(self.r)

    def numerator(self, sample_time: float) -> tuple[float, ...]:
        """N(w) = (1 − w)·R(w)/T [1/s], ascending powers of w (the closed loop's realisation)."""
        n = np.convolve([1.0, -1.0], self.r) / sample_time
        return tuple(float(c) for c in n)


def poly_at(coeffs: tuple[float, ...], w: np.ndarray) -> np.ndarray:
    """Σ c_k w^k by Horner (complex)."""
    out = np.full(np.shape(w), coeffs[-1], dtype=complex)
    for c in coeffs[-2::-1]:
        out = out * w + c
    return out


def _angles(coeffs: tuple[float, ...]) -> tuple[float, ...]:
    if len(coeffs) < 2:
        return ()
    roots = np.roots(np.asarray(coeffs, dtype=float))   # Σ c_k z^{−k} = 0 ⇔ Σ c_k z^{n−k} = 0
    return tuple(sorted({float(abs(np.angle(z))) for z in roots if abs(np.angle(z)) > 0.0}))


def _check_poles(d: tuple[float, ...], field: str) -> None:
    if len(d) > 1:
        radius = float(np.max(np.abs(np.roots(np.asarray(d)))))
        if not radius <= 1.0 - POLE_MARGIN:
            raise InputError(field, f"the filter must be stable: a root of D lies at |z| = {radius:.12g}, not inside "
                                    f"|z| ≤ 1 − {POLE_MARGIN:g}")


def velocity_transfer(spec: BackwardDifference | LowPass | MovingAverage | TransferFunctionFilter | None,
                      sample_time: float) -> VelocityTransfer:
    """V(z) of ``spec`` at the sample time T [s]; InputError naming the field (under ``velocity_filter``) for a
    cutoff at or above the Nyquist frequency, or a transfer function that is not a stable velocity estimate."""
    if spec is None or isinstance(spec, BackwardDifference):
        return DEFAULT_VELOCITY
    if isinstance(spec, LowPass):
        nyquist = 0.5 / sample_time
        if not spec.cutoff_hz < nyquist:
            raise InputError("velocity_filter.cutoff_hz", f"must be below the Nyquist frequency 1/(2T) = "
                                                          f"{nyquist:.6g} Hz")
        if not 2.0 * math.pi * spec.cutoff_hz * sample_time >= POLE_MARGIN:
            raise InputError("velocity_filter.cutoff_hz", f"must be at least {POLE_MARGIN / (2 * math.pi):.3g}/T = "
                                                          f"{POLE_MARGIN / (2 * math.pi * sample_time):.3g} Hz (its "
                                                          "pole would sit on the unit circle)")
        if spec.order == 1:
            a = math.exp(-2.0 * math.pi * spec.cutoff_hz * sample_time)
            return VelocityTransfer("low_pass", (-math.expm1(-2.0 * math.pi * spec.cutoff_hz * sample_time),),
                                    (1.0, -a))
        from scipy import signal  # here: importing scipy.signal costs ≈ 0.6 s of CPU, and only this filter needs it

        b, a = signal.butter(2, spec.cutoff_hz, fs=1.0 / sample_time)
        b, a = b / a[0], a / a[0]
        _check_poles(tuple(a), "velocity_filter.cutoff_hz")
        return VelocityTransfer("low_pass", tuple(float(c) for c in b), tuple(float(c) for c in a))
    if isinstance(spec, MovingAverage):
        n = spec.samples
        return VelocityTransfer("moving_average", (1.0 / n,) * n, (1.0,))
    return _transfer_function(spec, sample_time)


def _transfer_function(spec: TransferFunctionFilter, sample_time: float) -> VelocityTransfer:
    num = np.asarray(spec.numerator, dtype=float)
    den = np.asarray(spec.denominator, dtype=float)
    if den[0] == 0.0:
        raise InputError("velocity_filter.denominator", "D(0), the coefficient of z⁰, must not be 0 (a causal filter)")
    num, den = num / den[0], den / den[0]
    scale = float(np.sum(np.abs(num)))
    if not scale > 0.0 or abs(float(np.sum(num))) > GAIN_RTOL * scale:
        raise InputError("velocity_filter.numerator", "not a velocity: V(1) = N(1)/D(1) must be 0 (the sum of the "
                                                      f"numerator's coefficients 0 within {GAIN_RTOL:g} relative)")
    _check_poles(tuple(den), "velocity_filter.denominator")
    r = np.cumsum(num)[:-1] * sample_time          # N(w) = (1 − w)·R(w)/T
    d1 = float(np.sum(den))
    gain = float(np.sum(r)) / d1
    if not abs(gain - 1.0) <= GAIN_RTOL:
        raise InputError("velocity_filter.numerator", f"not a velocity: V'(1)·T must be 1 within {GAIN_RTOL:g} "
                                                      f"relative (a velocity in m/s), got {gain:.12g}")
    while len(r) > 1 and r[-1] == 0.0:
        r = r[:-1]
    while len(den) > 1 and den[-1] == 0.0:
        den = den[:-1]
    return VelocityTransfer("transfer_function", tuple(float(c) for c in r), tuple(float(c) for c in den))


DEFAULT_VELOCITY = VelocityTransfer("backward_difference", (1.0,), (1.0,))


@dataclass(frozen=True)
class Rendering:
    """What the wall renders besides K and B: the velocity the damper sees and the virtual mass M [kg]."""

    velocity: VelocityTransfer = DEFAULT_VELOCITY
    mass: float = 0.0
    """M [kg or kg·m²]; negative compensates the device's inertia."""
    spec: BackwardDifference | LowPass | MovingAverage | TransferFunctionFilter | None = field(default=None,
                                                                                             compare=False)
    """the filter's specification it was built from (the closed loop realises it again, optim.verification); None:
    not known (:func:`filter_spec` then writes the transfer function's coefficients out)."""

    @property
    def is_default(self) -> bool:
        """Today's wall C(z) = K + B(1 − z⁻¹)/T."""
        return self.mass == 0.0 and self.velocity.is_backward_difference

    def controller_response(self, theta: np.ndarray, beta: float, mu: float) -> np.ndarray:
        """β·T·V + μ·T²·A (dimensionless: β = BT/m, μ = M/m): the damper's and the mass's part of C·T²/m."""
        v = self.velocity.response(theta)
        out = beta * v
        if mu != 0.0:
            out = out + mu * v * -np.expm1(-1j * theta)
        return out


DEFAULT_RENDERING = Rendering()


def rendering(velocity_filter: BackwardDifference | LowPass | MovingAverage | TransferFunctionFilter | None,
              mass: float, sample_time: float) -> Rendering:
    """The Rendering of a controller's ``velocity_filter`` and ``mass`` at the sample time T [s] (InputError naming
    ``velocity_filter.…`` or ``mass``)."""
    if not (math.isfinite(mass) and abs(mass) <= MAX_VIRTUAL_MASS):
        raise InputError("mass", f"must be finite with |M| ≤ {MAX_VIRTUAL_MASS:g}")
    return Rendering(velocity_transfer(velocity_filter, sample_time), float(mass), velocity_filter)


def filter_spec(r: Rendering, sample_time: float) -> BackwardDifference | LowPass | MovingAverage | TransferFunctionFilter:
    """The specification of ``r``'s velocity filter: the one it was built from, else its V(z) as a transfer function
    (N = (1 − w)·R/T, D; built without the request's validation, whose coefficient count a long average exceeds)."""
    if r.spec is not None:
        return r.spec
    if r.velocity.is_backward_difference:
        return BackwardDifference()
    return TransferFunctionFilter.model_construct(kind="transfer_function",
                                                  numerator=list(r.velocity.numerator(sample_time)),
                                                  denominator=list(r.velocity.d))
