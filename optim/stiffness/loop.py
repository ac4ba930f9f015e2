"""The stiffness loop's frequency function in a form CasADi can differentiate.

For the wall C(z) = K + B(1 − z⁻¹)/T the closed loop has a pole at z = e^{jθ}
exactly when α = H(θ, β) = −1/G_n(e^{jθ}) + β(e^{−jθ} − 1) (dimensionless,
Table 1).  G_n comes from the exact ZOH matrices of models/discretize.py:

    G_n(e^{jθ}) = C·((z − 1)I − E)⁻¹·(Γ0 + z⁻¹Γ1)·e^{−jdθ},   E = Φ − I,

written with z − 1 = −2sin²(θ/2) + j·sin θ so nothing cancels near z = 1, and
E taken from the accurate form (A·Ψ(1), or φ₁(δ) and expm1 for the rigid
plant), never Φ − I formed by subtraction.  Complex numbers are carried as
(real, imaginary) pairs and the resolvent as a real 2n×2n solve.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from models.device import Device
from models.discretize import RigidZOH, phi1
from models.plants import stiffness_loop_plant

__all__ = ["LoopMatrices", "loop_matrices", "casadi_inverse_response", "casadi_loop_function", "numpy_h"]


@dataclass(frozen=True)
class LoopMatrices:
    """(E, Γ0, Γ1, C, d) of the sampled plant, dimensionless (time in T, mass in m)."""

    e: np.ndarray
    g0: np.ndarray
    g1: np.ndarray
    c: np.ndarray
    d: int

    @property
    def n(self) -> int:
        return self.e.shape[0]

    def flat(self) -> np.ndarray:
        """Parameter vector [vec(E) (column-major, as CasADi), Γ0, Γ1, C, d]."""
        return np.concatenate([self.e.flatten(order="F"), self.g0, self.g1, self.c, [float(self.d)]])


def loop_matrices(device: Device) -> LoopMatrices:
    plant = stiffness_loop_plant(device)
    if isinstance(plant, RigidZOH):
        _, g0, g1, c = plant.matrices()
        dl = plant.delta
        e = np.array([[0.0, phi1(dl)], [0.0, math.expm1(-dl)]])
        return LoopMatrices(e, np.asarray(g0, float), np.asarray(g1, float), np.asarray(c, float), plant.d)
    _, emat, g0, g1 = plant.accurate_matrices()
    return LoopMatrices(np.array(emat), np.array(g0), np.array(g1), np.array(plant.c, dtype=float), plant.d)


def _cmul(a, b):
    return a[0] * b[0] - a[1] * b[1], a[0] * b[1] + a[1] * b[0]


def casadi_inverse_response(theta, n: int, params):
    """(Re, Im) of 1/G_n(e^{jθ}) as CasADi expressions; ``params`` is the symbol laid out as LoopMatrices.flat()."""
    e = ca.reshape(params[0:n * n], n, n)
    g0 = params[n * n:n * n + n]
    g1 = params[n * n + n:n * n + 2 * n]
    c = params[n * n + 2 * n:n * n + 3 * n]
    d = params[n * n + 3 * n]
    wr, wi = -2 * ca.sin(theta / 2) ** 2, ca.sin(theta)          # z − 1
    eye = ca.DM.eye(n)
    m = ca.vertcat(ca.horzcat(wr * eye - e, -wi * eye), ca.horzcat(wi * eye, wr * eye - e))
    rhs = ca.vertcat(g0 + ca.cos(theta) * g1, -ca.sin(theta) * g1)   # Γ0 + z⁻¹Γ1
    x = ca.solve(m, rhs)
    nr, ni = ca.dot(c, x[0:n]), ca.dot(c, x[n:2 * n])
    mag2 = nr * nr + ni * ni
    # 1/G = e^{jdθ}·conj(N)/|N|²
    return _cmul((ca.cos(d * theta), ca.sin(d * theta)), (nr / mag2, -ni / mag2))


def casadi_loop_function(n: int) -> ca.Function:
    """Function (θ, β, params) → (Re H, Im H) with H = −1/G_n + β(e^{−jθ} − 1)."""
    theta, beta = ca.SX.sym("theta"), ca.SX.sym("beta")
    params = ca.SX.sym("p", n * n + 3 * n + 1)
    ir, ii = casadi_inverse_response(theta, n, params)
    hr = -ir + beta * (ca.cos(theta) - 1)
    hi = -ii - beta * ca.sin(theta)
    return ca.Function("H", [theta, beta, params], [hr, hi])


def numpy_h(device: Device, theta: np.ndarray, beta: float) -> np.ndarray:
    """H(θ, β) from the lead's plant (numpy), the reference the CasADi form is checked against."""
    plant = stiffness_loop_plant(device)
    return -plant.inverse_response(np.asarray(theta, float)) + beta * np.expm1(-1j * np.asarray(theta, float))
