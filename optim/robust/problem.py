"""The robust stiffest-wall NLP: one (K, B) and a margin constraint per scenario device, in CasADi.

Every scenario s is a device with its own sampled plant, so the same physical
wall is a different dimensionless point α_s = K·T_s²/m_s, β_s = B·T_s/m_s
(Table 1) on each scenario's boundary.  Decision variables (scaled):
k = K/K_ref, b = B/B_ref and one angle θ_{s,i} per tracked crossover of each
scenario; constraints, for every scenario s and tracked crossover i:

    Im H_s(θ_{s,i}, β_s)/|H_s| = 0          θ_{s,i} is a phase crossover of scenario s at β_s
    k ≤ g·Re H_s(θ_{s,i}, β_s)·(m_s/T_s²)/K_ref
    k ≤ g·H_s(π, β_s)·(m_s/T_s²)/K_ref      (the Nyquist crossover, when it is one)
    k ≤ K_cap/K_ref,   b ≤ B_cap/B_ref

H_s is optim.stiffness.loop's CasADi loop function (the exact ZOH matrices as
parameters).  Solvers are built once per structure (states, crossovers and
Nyquist flag of each scenario) and per thread, Ipopt silent, status always read.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from optim.stiffness.loop import casadi_loop_function
from optim.stiffness.problem import IPOPT_OPTIONS
from optim.solver_cache import thread_solver

__all__ = ["RobustKey", "RobustSolution", "solve_robust"]

_GLOBAL = 5                           # g, K_ref, B_ref, K_cap, B_cap


@dataclass(frozen=True)
class RobustKey:
    n_states: int
    scenarios: tuple[tuple[int, bool], ...]
    """(tracked interior crossovers, Nyquist constraint) of each scenario, in parameter order."""


@dataclass(frozen=True)
class RobustSolution:
    success: bool
    return_status: str
    iterations: int
    k: float
    b: float
    thetas: tuple[tuple[float, ...], ...]
    """the crossover angles of each scenario at the solution [rad per sample]."""


def _n_loop(n: int) -> int:
    return n * n + 3 * n + 1


def _build(key: RobustKey) -> ca.Function:
    n = key.n_states
    nl = _n_loop(n)
    h = casadi_loop_function(n)
    m_total = sum(m for m, _ in key.scenarios)
    x = ca.SX.sym("x", 2 + m_total)
    p = ca.SX.sym("p", _GLOBAL + len(key.scenarios) * (nl + 2))
    g_gain, k_ref, b_ref, k_cap, b_cap = (p[i] for i in range(_GLOBAL))
    k, b = x[0], x[1]
    eqs, ineqs = [], []
    col, off = 2, _GLOBAL
    for m, nyquist in key.scenarios:
        loop = p[off:off + nl]
        ks, bs = p[off + nl], p[off + nl + 1]
        off += nl + 2
        beta = b * b_ref / bs
        for _ in range(m):
            hr, hi = h(x[col], beta, loop)
            col += 1
            eqs.append(hi / ca.sqrt(hr * hr + hi * hi))       # sin(arg H): scale-free
            ineqs.append(k - g_gain * hr * ks / k_ref)
        if nyquist:
            hr, _ = h(np.pi, beta, loop)
            ineqs.append(k - g_gain * hr * ks / k_ref)
    ineqs.append(k - k_cap / k_ref)
    ineqs.append(b - b_cap / b_ref)
    name = "robust_" + str(n) + "_" + "_".join(f"{m}{int(q)}" for m, q in key.scenarios)
    return ca.nlpsol(name, "ipopt", {"x": x, "p": p, "f": -k, "g": ca.vertcat(*(eqs + ineqs))},
                     {**IPOPT_OPTIONS, "calc_lam_p": False})


def _solver(key: RobustKey) -> ca.Function:
    return thread_solver("robust-stiffness", key, lambda: _build(key))


def solve_robust(key: RobustKey, global_params: np.ndarray, scenario_params: list[np.ndarray], x0: np.ndarray,
                 b_bounds: tuple[float, float], theta_bounds: list[tuple[float, float]]) -> RobustSolution:
    """Solve with the scenarios' parameters ([loop flat, m/T², m/T] each) in the key's order."""
    solver = _solver(key)
    m_total = sum(m for m, _ in key.scenarios)
    n_ineq = m_total + sum(int(q) for _, q in key.scenarios) + 2
    params = np.concatenate([global_params, *scenario_params])
    lbx = [0.0, b_bounds[0]] + [t[0] for t in theta_bounds]
    ubx = [np.inf, b_bounds[1]] + [t[1] for t in theta_bounds]
    out = solver(x0=x0, p=params, lbx=lbx, ubx=ubx, lbg=[0.0] * m_total + [-np.inf] * n_ineq,
                 ubg=[0.0] * (m_total + n_ineq))
    stats = solver.stats()
    xs = np.asarray(out["x"]).ravel()
    thetas, col = [], 2
    for m, _ in key.scenarios:
        thetas.append(tuple(float(v) for v in xs[col:col + m]))
        col += m
    return RobustSolution(bool(stats["success"]), str(stats["return_status"]), int(stats.get("iter_count", -1)),
                          float(xs[0]), float(xs[1]), tuple(thetas))
