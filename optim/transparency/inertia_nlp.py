"""CasADi model of the force-feedforward crossover conditions (the local problem of optim/transparency/inertia.py).

Decision variables: y = log K_f, the filter cutoff t = θ_c [rad/sample] and one
angle θ_i per tracked phase crossover.  For each crossover i (of the plant of
grasp h(i)), with h̃ = -conj(G_1)·Q and D = cosⁿφ/Q (models/filters.py) at the
plant's own cutoff angle σ_h·t (σ = 1 for the plants of one device; a robust
design's devices with other sample times T_h see the same cutoff in Hz at the
angle t·T_h/T_ref):

    Im h̃(θ_i; t)/|h̃| = 0                    θ_i is a phase crossover at this cutoff
    Re h̃(θ_i; t)/|h̃| ≥ 1/2                  ... of the kind that can destabilise (h > 0)
    y + log ρ + log|D(θ_i; t)| + log|G_1(θ_i)| ≤ 0    margin ρ = 10^{GM/20} at that crossover

This is the local reduction of the semi-infinite constraint "ρ·K_f ≤ h(θ) at
every crossover"; optim/transparency/inertia.py adds crossovers the exact analysis finds
(exchange method) and re-verifies the answer.  G_1 enters in modal form
G_1(z) = z^{-d}·Σ_i (r0_i + r1_i z⁻¹)/(z - λ_i) + D_dir·z^{-d-1}, exact for the
diagonalisable Φ of a damped device (checked against the exact response).  Plants
with fewer modes than the largest (a device without a force-sensor filter, T_f = 0,
has one state fewer) are padded with modes of zero residue, which add exactly 0.

Solvers are built once per structure (modes, filter order, crossovers, objective)
and per thread (CasADi/Ipopt objects are not thread-safe); numbers go in as p.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from models.feedforward import FeedforwardPlant
from models.filters import butterworth_polynomial
from optim.solver_cache import thread_solver

__all__ = ["ModalPlant", "modal_plant", "CrossoverNLP", "solve_crossover_nlp"]

_IPOPT = {"ipopt.print_level": 0, "print_time": 0, "ipopt.sb": "yes", "ipopt.tol": 1e-12,
          "ipopt.bound_relax_factor": 0.0, "ipopt.constr_viol_tol": 1e-10,
          "ipopt.max_iter": 200}


@dataclass(frozen=True)
class ModalPlant:
    """G_1 in modal form: poles λ_i of Φ, carried as q_i = λ_i − 1, and residues of the two input matrices.

    The poles of a finely sampled loop crowd z = 1 (λ = e^{μT} with |μT| ≪ 1): z − λ is evaluated as
    (z − 1) − q with z − 1 = expm1(jθ) and q = expm1(μT) from the continuous eigenvalues μ, so neither
    difference cancels."""

    q: np.ndarray
    r0: np.ndarray
    r1: np.ndarray
    direct: float
    d: int

    @property
    def poles(self) -> np.ndarray:
        return self.q + 1.0

    def params(self) -> np.ndarray:
        return np.concatenate([self.q.real, self.q.imag, self.r0.real, self.r0.imag,
                               self.r1.real, self.r1.imag, [self.direct, float(self.d)]])

    def response(self, theta: np.ndarray) -> np.ndarray:
        theta = np.atleast_1d(theta)
        zinv = np.exp(-1j * theta)[:, None]
        zm1 = np.expm1(1j * theta)[:, None]
        g = ((self.r0 + self.r1 * zinv) / (zm1 - self.q)).sum(axis=1) + self.direct * zinv[:, 0]
        return g * np.exp(-1j * self.d * theta)


def modal_plant(plant: FeedforwardPlant) -> tuple[ModalPlant, float]:
    """The modal form and its largest relative error against the exact response on a test grid.

    Eigenvectors and eigenvalues come from the continuous A (dimensionless, T = 1), whose eigenvalues are
    spread, not from Φ = e^A, whose eigenvalues crowd 1 at fast sampling (eig(Φ) then loses ~eps/|λ − 1|
    of each residue: 1e-7 relative at T = 3.3e-5 s on the LHifAM, 1e-12 from A)."""
    _, g0, g1, c = plant.matrices()
    mu, v = np.linalg.eig(plant.zoh.a)
    cv = c @ v
    modal = ModalPlant(q=np.expm1(mu.astype(complex)), r0=cv * np.linalg.solve(v, g0),
                       r1=cv * np.linalg.solve(v, g1), direct=plant.direct, d=plant.d)
    theta = np.geomspace(max(plant.theta_min, 1e-6), math.pi, 64)
    exact = plant.response(theta)
    err = float(np.max(np.abs(modal.response(theta) - exact) / np.abs(exact)))
    return modal, err


def _cmul(a, b):
    return (a[0] * b[0] - a[1] * b[1], a[0] * b[1] + a[1] * b[0])


def _g1_expr(theta, p, n_modes: int):
    """Re, Im of G_1(e^{jθ}) from the parameter block p of one ModalPlant."""
    k = n_modes
    qr, qi, r0r, r0i, r1r, r1i = (p[j * k:(j + 1) * k] for j in range(6))
    direct, d = p[6 * k], p[6 * k + 1]
    zr, zi = ca.cos(theta), ca.sin(theta)
    zinv = (zr, -zi)
    zm1r = -2 * ca.sin(theta / 2) ** 2                 # Re(z − 1) without cancellation near θ = 0
    acc = (0, 0)
    for i in range(k):
        wr, wi = zm1r - qr[i], zi - qi[i]              # z − λ_i = (z − 1) − q_i
        den = wr * wr + wi * wi
        inv = (wr / den, -wi / den)
        num = (r0r[i] + r1r[i] * zinv[0] - r1i[i] * zinv[1], r0i[i] + r1r[i] * zinv[1] + r1i[i] * zinv[0])
        t = _cmul(num, inv)
        acc = (acc[0] + t[0], acc[1] + t[1])
    acc = (acc[0] + direct * zinv[0], acc[1] + direct * zinv[1])
    return _cmul(acc, (ca.cos(d * theta), -ca.sin(d * theta)))


def _filter_expr(theta, t, order: int):
    """(log cosⁿφ, Re Q, Im Q) with φ = atan2(sin(θ/2), tan(t/2)cos(θ/2))."""
    phi = ca.atan2(ca.sin(theta / 2), ca.tan(t / 2) * ca.cos(theta / 2))
    s, c = ca.sin(phi), ca.cos(phi)
    qr, qi = 0, 0
    for k, a in enumerate(butterworth_polynomial(order)):      # a (j s)^(n-k) c^k
        m = order - k
        term = a * s**m * c**k
        if m % 4 == 0:
            qr += term
        elif m % 4 == 1:
            qi += term
        elif m % 4 == 2:
            qr -= term
        else:
            qi -= term
    return order * ca.log(c), qr, qi


@dataclass(frozen=True)
class CrossoverNLP:
    solver: ca.Function
    n_cross: int


def _build(n_modes: int, order: int, n_cross: int, objective: str) -> CrossoverNLP:
    y, t = ca.SX.sym("y"), ca.SX.sym("t")
    th = ca.SX.sym("th", n_cross)
    n_p = 6 * n_modes + 2
    p = ca.SX.sym("p", 1 + n_cross * (n_p + 1))    # [log ρ], then per crossover its plant block and σ
    log_rho = p[0]
    g = []
    for i in range(n_cross):
        blk = p[1 + i * (n_p + 1): 1 + i * (n_p + 1) + n_p]
        sigma = p[1 + i * (n_p + 1) + n_p]
        gr, gi = _g1_expr(th[i], blk, n_modes)
        log_cn, qr, qi = _filter_expr(th[i], sigma * t, order)
        hr, hi = -(gr * qr + gi * qi), -(gr * qi - gi * qr)          # -conj(G)·Q
        ah = ca.sqrt(hr * hr + hi * hi)
        g += [hi / ah, hr / ah,
              y + log_rho + log_cn - 0.5 * ca.log(qr * qr + qi * qi) + 0.5 * ca.log(gr * gr + gi * gi)]
    x = ca.vertcat(y, t, th)
    f = -y if objective == "max_gain" else -t
    nlp = {"x": x, "p": p, "f": f, "g": ca.vertcat(*g)}
    return CrossoverNLP(solver=ca.nlpsol("ff", "ipopt", nlp, _IPOPT), n_cross=n_cross)


def _solver(n_modes: int, order: int, n_cross: int, objective: str) -> CrossoverNLP:
    key = (n_modes, order, n_cross, objective)
    return thread_solver("inertia", key, lambda: _build(*key))


@dataclass(frozen=True)
class NLPResult:
    log_gain: float
    cutoff_angle: float
    angles: tuple[float, ...]
    success: bool
    return_status: str


def _padded(plant: ModalPlant, n_modes: int) -> ModalPlant:
    """The plant with modes of zero residue (pole 0, off the unit circle) up to n_modes: the same G_1."""
    extra = n_modes - len(plant.q)
    if extra == 0:
        return plant
    zeros = np.zeros(extra, complex)
    return ModalPlant(np.concatenate([plant.q, zeros - 1.0]), np.concatenate([plant.r0, zeros]),
                      np.concatenate([plant.r1, zeros]), plant.direct, plant.d)


def solve_crossover_nlp(plants: list[ModalPlant], crossings: list[tuple[int, float]], order: int,
                        log_rho: float, t0: float, t_bounds: tuple[float, float], y0: float,
                        objective: str, y_fixed: float = 0.0,
                        cutoff_scales: list[float] | None = None) -> NLPResult:
    """One local solve; ``crossings`` are (plant index, θ_i0) pairs tracked from the exact analysis.

    ``cutoff_scales[j]`` is plant j's cutoff angle over t (default 1: every plant at the angle t).
    """
    n_modes = max(len(pl.q) for pl in plants)
    scales = [1.0] * len(plants) if cutoff_scales is None else [float(v) for v in cutoff_scales]
    nlp = _solver(n_modes, order, len(crossings), objective)
    p = [log_rho] + [v for j, _ in crossings for v in (*_padded(plants[j], n_modes).params(), scales[j])]
    # target mode: K_f is given, so y is fixed by its bounds (Ipopt makes it a parameter)
    y_lo, y_hi = (-50.0, 50.0) if objective == "max_gain" else (y_fixed, y_fixed)
    lbx = [y_lo, t_bounds[0]] + [a / 1.5 for _, a in crossings]
    ubx = [y_hi, t_bounds[1]] + [min(math.pi * (1 - 1e-12), 1.5 * a) for _, a in crossings]
    x0 = [y0 if objective == "max_gain" else y_fixed, t0] + [a for _, a in crossings]
    lbg = [0.0, 0.5, -ca.inf] * len(crossings)
    ubg = [0.0, ca.inf, 0.0] * len(crossings)
    sol = nlp.solver(x0=x0, p=p, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
    stats = nlp.solver.stats()
    x = np.asarray(sol["x"]).ravel()
    return NLPResult(log_gain=float(x[0]), cutoff_angle=float(x[1]), angles=tuple(float(v) for v in x[2:]),
                     success=bool(stats["success"]), return_status=str(stats["return_status"]))
