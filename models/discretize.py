"""Exact zero-order-hold discretisation with a loop delay of any real length.

Everything here is dimensionless (Table 1): time in sample periods, masses in
units of the total mass m, so a plant's sampled transfer is G_n(z) = G(z)·m/T².
The delay t_d = (d + f)·T is split into whole samples d (a factor z^-d) and a
fraction f ∈ [0, 1) handled exactly by the modified z-transform written as two
input matrices (Γ0 acts during the last (1-f) of a period, Γ1 during the first f):

    x[k+1] = Φ x[k] + Γ0 u[k-d] + Γ1 u[k-d-1],   Γ0 = Ψ(1-f) B,  Γ1 = e^{A(1-f)} Ψ(f) B,

with Ψ(σ) = ∫₀^σ e^{As} ds.  No Padé approximation, no rounding of the delay.

Numerical traps avoided (FIELD-NOTES.md): the rigid plant's coefficients use the
series of φ₁(x) = (1-e^{-x})/x and φ₂(x) = (x-1+e^{-x})/x² below |x| = 1, and the
poles are handled through their distance from 1 (1 - e^{-δ} = -expm1(-δ)), never
through e^{-δ} itself, so δ = 1e-12 keeps full precision.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction
from functools import lru_cache

import numpy as np
from scipy.linalg import expm

__all__ = [
    "phi1",
    "phi2",
    "split_delay",
    "split_delay_array",
    "RigidZOH",
    "rigid_coefficients",
    "StateSpaceZOH",
    "cable_state_space",
    "fold_angle",
]

_EPS = float(np.finfo(float).eps)

_SERIES_TERMS = 30


@lru_cache(maxsize=None)
def _series(name: str) -> tuple[float, ...]:
    """Taylor coefficients in x, exact rationals rounded once to double."""
    n = _SERIES_TERMS
    fact = [math.factorial(k) for k in range(n + 3)]
    p = [Fraction((-1) ** k, fact[k]) for k in range(n)]                 # e^{-x}
    f1 = [Fraction((-1) ** k, fact[k + 1]) for k in range(n)]            # φ₁
    f2 = [Fraction((-1) ** k, fact[k + 2]) for k in range(n)]            # φ₂

    def mul(a: list[Fraction], b: list[Fraction]) -> list[Fraction]:
        return [sum((a[i] * b[k - i] for i in range(k + 1)), Fraction(0)) for k in range(n)]

    if name == "phi1":
        c = f1
    elif name == "phi2":
        c = f2
    elif name == "rigid_c":
        # c(δ) = φ₁² - (1 + e^{-δ}) φ₂ = -δ/6 + ...: N(-1) of the undelayed rigid plant.
        one_plus_p = [p[0] + 1] + p[1:]
        c = [a - b for a, b in zip(mul(f1, f1), mul(one_plus_p, f2))]
    else:  # pragma: no cover - programming error
        raise KeyError(name)
    return tuple(float(v) for v in c)


def _horner(coeffs: tuple[float, ...], x: float) -> float:
    acc = 0.0
    for c in reversed(coeffs):
        acc = acc * x + c
    return acc


def phi1(x: float) -> float:
    """φ₁(x) = (1 - e^{-x})/x, with φ₁(0) = 1."""
    if abs(x) < 1.0:
        return _horner(_series("phi1"), x)
    return -math.expm1(-x) / x


def phi2(x: float) -> float:
    """φ₂(x) = (x - 1 + e^{-x})/x², with φ₂(0) = 1/2 (series below |x| = 1)."""
    if abs(x) < 1.0:
        return _horner(_series("phi2"), x)
    return (x + math.expm1(-x)) / (x * x)


def _rigid_c(delta: float) -> float:
    if delta < 1.0:
        return _horner(_series("rigid_c"), delta)
    p = math.exp(-delta)
    return phi1(delta) ** 2 - (1.0 + p) * phi2(delta)


def split_delay(delay_samples: float) -> tuple[int, float]:
    """d = t_d/T split into whole samples and a fraction in [0, 1).

    A fraction within 64 ulp of an integer is taken as that integer: 0.003/0.001
    is 2.9999999999999996 in binary floating point, and the intent is 3.  K_cr is
    continuous in the delay, so this changes nothing beyond rounding.
    """
    if delay_samples < 0 or not math.isfinite(delay_samples):
        raise ValueError("delay must be finite and non-negative")
    nearest = round(delay_samples)
    if abs(delay_samples - nearest) <= 64 * _EPS * max(1.0, delay_samples):
        return int(nearest), 0.0
    whole = math.floor(delay_samples)
    return int(whole), float(delay_samples - whole)


def split_delay_array(delay_samples: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """split_delay of many delays at once: (whole samples as int, fraction), the same 64-ulp snap."""
    ds = np.asarray(delay_samples, float)
    nearest = np.round(ds)
    snap = np.abs(ds - nearest) <= 64 * np.finfo(float).eps * np.maximum(1.0, ds)
    whole = np.floor(ds)
    return np.where(snap, nearest, whole).astype(np.int64), np.where(snap, 0.0, ds - whole)


@dataclass(frozen=True)
class RigidZOH:
    """Rigid plant 1/(ms² + bs) (eq. 14) under ZOH and delay, in closed form.

    G_n(z) = N(z) / ((z - 1)(z - p)) · z^{-d},  p = e^{-δ}, with N from the
    closed-form Φ, Γ0, Γ1 above written with φ₁, φ₂.
    """

    delta: float
    d: int
    f: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "_coef", self._compute_coefficients())
        object.__setattr__(self, "_c0", (phi2(self.delta), _rigid_c(self.delta)))

    def coefficients(self) -> tuple[float, float, float, float, float, float, float]:
        """(1 − p, Φ₁₂, Γ0 pos, Γ0 vel, Γ1 pos, Γ1 vel, 1 − f): the closed-form ZOH coefficients
        (dimensionless), each from φ₁/φ₂/expm1 without cancellation (batched evaluators read them)."""
        return self._coef  # type: ignore[attr-defined]

    def f0_numerator(self) -> tuple[float, float]:
        """(φ₂(δ), c(δ)): N(z) = φ₂·(z + 1) + c of the whole-sample (f = 0) form, its zero near −1 kept."""
        return self._c0  # type: ignore[attr-defined]

    def _compute_coefficients(self) -> tuple[float, float, float, float, float, float, float]:
        dl, f = self.delta, self.f
        s0 = 1.0 - f
        one_minus_p = -math.expm1(-dl)
        phi12 = phi1(dl)                                   # Φ[0,1]
        g0p = s0 * s0 * phi2(dl * s0)
        g0v = s0 * phi1(dl * s0)
        g1p = f * f * phi2(dl * f) + s0 * phi1(dl * s0) * f * phi1(dl * f)
        g1v = math.exp(-dl * s0) * f * phi1(dl * f)
        return one_minus_p, phi12, g0p, g0v, g1p, g1v, s0

    def numerator(self, z: np.ndarray) -> np.ndarray:
        one_minus_p, phi12, g0p, g0v, g1p, g1v, _ = self.coefficients()
        if self.f == 0.0:
            # φ₂·(z + 1) + c(δ): the zero near z = -1 without cancellation.
            a, c = self._c0  # type: ignore[attr-defined]
            return a * (z + 1.0) + c
        zinv = 1.0 / z
        gpos = g0p + g1p * zinv
        gvel = g0v + g1v * zinv
        return gpos * ((z - 1.0) + one_minus_p) + phi12 * gvel

    def inverse_response(self, theta: np.ndarray) -> np.ndarray:
        """1/G_n(e^{jθ}) for θ in (0, π]."""
        theta = np.asarray(theta, dtype=float)
        z = np.exp(1j * theta)
        zm1 = np.expm1(1j * theta)                         # z - 1 without cancellation
        one_minus_p = self._coef[0]  # type: ignore[attr-defined]
        den = zm1 * (zm1 + one_minus_p)
        out = den * np.exp(1j * self.d * theta) / self.numerator(z)
        at_pi = theta == math.pi
        if np.any(at_pi) and self.inverse_at_nyquist() is not None:
            out[at_pi] = self.inverse_at_nyquist()
        return out

    def inverse_at_nyquist(self) -> float | None:
        """1/G_n(−1), real, in closed form: z = −1, z + 1 = 0 and (−1)^d exactly (issue 34).  The complex formula at
        θ = π carries sin(π) ≈ 1.2e-16 into z + 1, and with a whole delay the numerator there is c(δ) = O(δ²)
        (the ZOH zero beside −1): the rounding then moved the Nyquist crossover's K by ~1.3e-13/δ² (a 4.1× error at
        δ ≈ 1e-16, 60-digit eigenvalues)."""
        one_minus_p, phi12, g0p, g0v, g1p, g1v, _ = self.coefficients()
        den = -2.0 * (one_minus_p - 2.0)
        if self.f == 0.0:
            num = self._c0[1]  # type: ignore[attr-defined]
        else:
            num = (g0p - g1p) * (one_minus_p - 2.0) + phi12 * (g0v - g1v)
        if num == 0.0:
            return None      # a zero on −1 (δ = 0): H(π) is a pole; the complex formula's value stands, as before
        sign = -1.0 if self.d % 2 else 1.0
        return sign * den / num

    def response(self, theta: np.ndarray) -> np.ndarray:
        return 1.0 / self.inverse_response(theta)

    def pole_angles(self) -> tuple[float, ...]:
        return ()

    def zero_angles(self) -> tuple[float, ...]:
        return ()

    def matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(Φ, Γ0, Γ1, C) of the position/velocity model (dimensionless)."""
        one_minus_p, phi12, g0p, g0v, g1p, g1v, _ = self.coefficients()
        phi = np.array([[1.0, phi12], [0.0, 1.0 - one_minus_p]])
        return phi, np.array([g0p, g0v]), np.array([g1p, g1v]), np.array([1.0, 0.0])


def _horner_array(coeffs: tuple[float, ...], x: np.ndarray) -> np.ndarray:
    acc = np.zeros_like(x)
    for c in reversed(coeffs):
        acc = acc * x + c
    return acc


def _phi_array(name: str, x: np.ndarray) -> np.ndarray:
    """phi1/phi2 of arrays: the same series below |x| = 1, the same closed forms above."""
    small = np.abs(x) < 1.0
    with np.errstate(divide="ignore", invalid="ignore"):
        big = -np.expm1(-x) / x if name == "phi1" else (x + np.expm1(-x)) / (x * x)
    return np.where(small, _horner_array(_series(name), np.where(small, x, 0.0)), big)


def rigid_coefficients(delta: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, ...]:
    """RigidZOH.coefficients() and f0_numerator() of many plants at once (arrays of δ and the delay fraction f):
    (1 − p, Φ₁₂, Γ0 pos, Γ0 vel, Γ1 pos, Γ1 vel, 1 − f, φ₂(δ), c(δ)), the same formulas elementwise."""
    delta, f = np.asarray(delta, float), np.asarray(f, float)
    s0 = 1.0 - f
    one_minus_p = -np.expm1(-delta)
    phi12 = _phi_array("phi1", delta)
    # each φ once (the same values as evaluating it where it appears: elementwise, deterministic)
    phi1_s0, phi1_f = _phi_array("phi1", delta * s0), _phi_array("phi1", delta * f)
    g0p = s0 * s0 * _phi_array("phi2", delta * s0)
    g0v = s0 * phi1_s0
    g1p = f * f * _phi_array("phi2", delta * f) + s0 * phi1_s0 * f * phi1_f
    g1v = np.exp(-delta * s0) * f * phi1_f
    a0 = _phi_array("phi2", delta)
    small = delta < 1.0
    p = np.exp(-delta)
    c_big = phi12 ** 2 - (1.0 + p) * a0
    c0 = np.where(small, _horner_array(_series("rigid_c"), np.where(small, delta, 0.0)), c_big)
    return one_minus_p, phi12, g0p, g0v, g1p, g1v, s0, a0, c0


def cable_state_space(mu_r: float, mu_d: float, delta_r: float, delta_d: float,
                      kappa: float, delta_c: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Two-mass model of eq. 15-18 in centre-of-mass coordinates (dimensionless).

    States [X, e, V, ė] with X = μ_r x_r + μ_d x_d and e = x_r - x_d, so the
    rigid-body integrator is an exactly zero column of A and stays exactly at
    z = 1 after discretisation.  Input: motor force; output: motor position x_r
    (the collocated encoder: G_r = p_d/p of eq. 15).
    """
    dl = delta_r + delta_d
    a = np.zeros((4, 4))
    a[0, 2] = 1.0
    a[1, 3] = 1.0
    a[2, 2] = -dl
    a[2, 3] = -(delta_r * mu_d - delta_d * mu_r)
    a[3, 1] = -kappa * (1.0 / mu_r + 1.0 / mu_d)
    a[3, 2] = -delta_r / mu_r + delta_d / mu_d
    a[3, 3] = -(delta_r * mu_d / mu_r + delta_d * mu_r / mu_d + delta_c / mu_r + delta_c / mu_d)
    b = np.array([0.0, 0.0, 1.0, 1.0 / mu_r])
    c = np.array([1.0, mu_d, 0.0, 0.0])
    return a, b, c


def _phi_psi_b(a: np.ndarray, b: np.ndarray, sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """(e^{Aσ}, Ψ(σ)B) from one augmented matrix exponential."""
    n = a.shape[0]
    m = np.zeros((n + 1, n + 1))
    m[:n, :n] = a
    m[:n, n] = b
    e = expm(m * sigma)
    return e[:n, :n], e[:n, n]


@dataclass(frozen=True)
class StateSpaceZOH:
    """Any continuous plant (A, B, C) (dimensionless) under ZOH and delay d + f.

    The resolvent is evaluated as ((z - 1)I - E)^{-1} with E = Φ - I = A·Ψ(1),
    never Φ - I formed by subtraction.
    """

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    d: int
    f: float = 0.0
    zeros_hint: tuple[float, ...] = ()
    #: the zeros as a polynomial in s (highest power first) and the scale of its roots (the hint of each root r is
    #: |Im r·zeros_scale|): found by np.roots when zero_angles() is first asked (issue 32: ~30 µs a plant, that the
    #: cable brackets never ask for), the bits zeros_hint would hold
    zeros_poly: tuple[float, ...] = ()
    zeros_scale: float = 1.0
    _cache: dict = field(default_factory=dict, compare=False, repr=False)

    def accurate_matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(Φ, E = A·Ψ(1), Γ0, Γ1): E from the accurate form, never Φ − I by subtraction (cached)."""
        if "m" not in self._cache:
            n = self.a.shape[0]
            big = np.zeros((2 * n, 2 * n))
            big[:n, :n] = self.a
            big[:n, n:] = np.eye(n)
            e = expm(big)
            phi, psi = e[:n, :n], e[:n, n:]
            emat = self.a @ psi
            s0 = 1.0 - self.f
            e0, g0 = _phi_psi_b(self.a, self.b, s0)
            if self.f > 0.0:
                _, pf = _phi_psi_b(self.a, self.b, self.f)
                g1 = e0 @ pf
            else:
                g1 = np.zeros(n)
            self._cache["m"] = (phi, emat, g0, g1)
        return self._cache["m"]

    def inverse_response(self, theta: np.ndarray) -> np.ndarray:
        """1/G_n(e^{jθ}); exactly 0 on a pole of G on the unit circle (an undamped mode sampled at its angle).

        With every damping 0 the cable mode's poles lie on the unit circle, and a scan evaluates G exactly at
        their angles (pole_angles() are hints): the modal resolvent divides by 0 there (inf, then inf·0 = nan in
        the sums).  The limit of 1/G at a pole is 0, which is what is returned, not a NaN (nor a
        FloatingPointError under the service's np.errstate(invalid="raise"))."""
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            g = self.response(theta)
            inv = 1.0 / g
        pole = ~np.isfinite(g)
        if pole.any():
            inv = np.where(pole, 0.0, inv)
        return inv

    def modal_form(self):
        """Split off an exact integrator (E's first column is exactly 0) and diagonalise the rest.

        With E = [[0, e₁₂ᵀ], [0, E₂₂]] the resolvent is solved as x₂ = ((z-1)I - E₂₂)⁻¹Γ₂
        (E₂₂ = V Λ V⁻¹, O(n) per frequency) and x₁ = (Γ₁ + e₁₂ᵀx₂)/(z - 1), so the integrator
        never meets the slow pole in one sum (their modal terms would cancel by ~θ/δ).
        Used only when V is well conditioned (error ≈ cond(V)·ε ≤ 1e-12); else None.
        """
        if "modal" not in self._cache:
            _, emat, g0, g1 = self.accurate_matrices()
            modal = None
            if emat.shape[0] > 1 and np.all(emat[:, 0] == 0.0):
                lam, v = np.linalg.eig(emat[1:, 1:])
                if np.linalg.cond(v) < 1e4:
                    vinv = np.linalg.inv(v)
                    e12v = emat[0, 1:] @ v
                    modal = (lam, self.c[0], self.c[1:] @ v, e12v, vinv @ g0[1:], vinv @ g1[1:], g0[0], g1[0])
            self._cache["modal"] = modal
        return self._cache["modal"]

    def response(self, theta: np.ndarray) -> np.ndarray:
        """G_n(e^{jθ}) = C ((z-1)I - E)⁻¹ (Γ0 + Γ1 z⁻¹) z^{-d} (both paths exact)."""
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        zm1 = np.expm1(1j * theta)
        zinv = np.exp(-1j * theta)
        delay = np.exp(-1j * self.d * theta)
        modal = self.modal_form()
        if modal is not None:
            lam, c1, c2v, e12v, r0, r1, g0_1, g1_1 = modal
            y = (r0[None, :] + zinv[:, None] * r1[None, :]) / (zm1[:, None] - lam[None, :])   # V⁻¹x₂
            x1 = (g0_1 + zinv * g1_1 + y @ e12v) / zm1
            return (c1 * x1 + y @ c2v) * delay
        _, emat, g0, g1 = self.accurate_matrices()
        n = emat.shape[0]
        mats = zm1[:, None, None] * np.eye(n)[None] - emat[None]
        rhs = g0[None, :] + zinv[:, None] * g1[None, :]
        x = np.linalg.solve(mats, rhs[..., None])[..., 0]
        return (x @ self.c) * delay

    def pole_angles(self) -> tuple[float, ...]:
        """Angles of the oscillatory poles (cached: an eigenvalue solve, ~90 µs, asked for on every K_cr call)."""
        if "angles" not in self._cache:
            lam = np.linalg.eigvals(self.a)
            self._cache["angles"] = tuple(fold_angle(abs(v.imag)) for v in lam if abs(v.imag) > 0)
        return self._cache["angles"]

    def zero_angles(self) -> tuple[float, ...]:
        return tuple(fold_angle(abs(w)) for w in self.zero_hints())

    def zero_hints(self) -> tuple[float, ...]:
        """zeros_hint, or |Im| of each root of zeros_poly times zeros_scale (cached), in np.roots' order."""
        if self.zeros_hint or not self.zeros_poly:
            return self.zeros_hint
        if "zeros" not in self._cache:
            zeros = np.roots(list(self.zeros_poly)) * self.zeros_scale
            self._cache["zeros"] = tuple(float(abs(z.imag)) for z in zeros)
        return self._cache["zeros"]

    def matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        phi, _, g0, g1 = self.accurate_matrices()
        return phi, g0, g1, self.c


def fold_angle(angle: float) -> float:
    """An angle per sample folded into [0, π] (aliasing of a sampled mode)."""
    a = math.fmod(angle, 2 * math.pi)
    return 2 * math.pi - a if a > math.pi else a
