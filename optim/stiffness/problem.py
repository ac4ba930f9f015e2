"""The stiffest-wall NLP in CasADi, built once per problem structure and per thread.

Decision variables (scaled): a = α/α_ref, b = β/β_ref and one angle θ_i per
tracked interior phase crossover.  Constraints:

    Im H(θ_i, β)/|H| = 0                  θ_i is a phase crossover at this β
    α ≤ g·Re H(θ_i, β)                    gain margin at every tracked crossover, g = 10^(−GM/20)
    α ≤ g·H(π, β)                         the Nyquist crossover (H(π) is real for every β)
    α ≤ α_cap,  β ≤ β_cap                 stiffness and damping limits of the request
    (α/2)·s_j − β·c_j ≤ δ                 passivity cuts at fixed angles θ_j (ARCHITECTURE.md form)

Every number that depends on the device is a parameter, so one solver serves
every device with the same structure, and Ipopt's multipliers give the
parametric sensitivity of the optimum: d(−a*)/dp = ∂L/∂p = lam_p (envelope theorem).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from optim.solver_cache import thread_solver
from optim.stiffness.loop import casadi_loop_function

__all__ = ["ProblemKey", "ProblemSolution", "solve_problem", "N_CUTS", "IPOPT_OPTIONS"]

N_CUTS = 10
IPOPT_OPTIONS = {"ipopt.print_level": 0, "print_time": 0, "ipopt.sb": "yes", "ipopt.tol": 1e-11,
                 "ipopt.acceptable_tol": 1e-9, "ipopt.max_iter": 200,
                 "ipopt.bound_relax_factor": 1e-12, "calc_lam_p": True}


@dataclass(frozen=True)
class ProblemKey:
    n_states: int
    n_crossovers: int
    nyquist: bool
    cuts: int


@dataclass(frozen=True)
class ProblemSolution:
    success: bool
    return_status: str
    iterations: int
    a: float
    b: float
    thetas: tuple[float, ...]
    lam_p: np.ndarray
    lam_x: np.ndarray
    lam_g: np.ndarray


def n_params(key: ProblemKey) -> int:
    n = key.n_states
    return n * n + 3 * n + 1 + 6 + 2 * key.cuts


def _build(key: ProblemKey) -> ca.Function:
    n, m = key.n_states, key.n_crossovers
    h = casadi_loop_function(n)
    x = ca.SX.sym("x", 2 + m)
    p = ca.SX.sym("p", n_params(key))
    nl = n * n + 3 * n + 1
    loop = p[0:nl]
    g_gain, a_ref, b_ref, a_cap, b_cap, delta = (p[nl + k] for k in range(6))
    s_cut, c_cut = p[nl + 6:nl + 6 + key.cuts], p[nl + 6 + key.cuts:nl + 6 + 2 * key.cuts]
    a, b = x[0], x[1]
    alpha, beta = a * a_ref, b * b_ref
    eqs, ineqs = [], []
    for i in range(m):
        hr, hi = h(x[2 + i], beta, loop)
        eqs.append(hi / ca.sqrt(hr * hr + hi * hi))      # sin(arg H): scale-free, whatever |H| is
        ineqs.append(a - g_gain * hr / a_ref)
    if key.nyquist:
        hr, _ = h(np.pi, beta, loop)
        ineqs.append(a - g_gain * hr / a_ref)
    ineqs.append(a - a_cap / a_ref)
    ineqs.append(b - b_cap / b_ref)
    for j in range(key.cuts):
        ineqs.append((alpha * s_cut[j] / 2 - beta * c_cut[j] - delta) / a_ref)
    g = ca.vertcat(*(eqs + ineqs))
    return ca.nlpsol(f"stiffness_{n}_{m}_{int(key.nyquist)}_{key.cuts}", "ipopt",
                     {"x": x, "p": p, "f": -a, "g": g}, IPOPT_OPTIONS)


def solver_for(key: ProblemKey) -> ca.Function:
    """This thread's solver for the structure (CasADi solvers are not thread-safe)."""
    return thread_solver("stiffness", key, lambda: _build(key))


def solve_problem(key: ProblemKey, params: np.ndarray, x0: np.ndarray,
                  b_bounds: tuple[float, float], theta_bounds: list[tuple[float, float]]) -> ProblemSolution:
    solver = solver_for(key)
    m = key.n_crossovers
    n_ineq = m + int(key.nyquist) + 2 + key.cuts
    lbx = [0.0, b_bounds[0]] + [t[0] for t in theta_bounds]
    ubx = [np.inf, b_bounds[1]] + [t[1] for t in theta_bounds]
    out = solver(x0=x0, p=params, lbx=lbx, ubx=ubx, lbg=[0.0] * m + [-np.inf] * n_ineq, ubg=[0.0] * (m + n_ineq))
    stats = solver.stats()
    xs = np.asarray(out["x"]).ravel()
    return ProblemSolution(bool(stats["success"]), str(stats["return_status"]), int(stats.get("iter_count", -1)),
                           float(xs[0]), float(xs[1]), tuple(float(v) for v in xs[2:]),
                           np.asarray(out["lam_p"]).ravel(), np.asarray(out["lam_x"]).ravel(),
                           np.asarray(out["lam_g"]).ravel())
