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
    k·u_j − b·v_j ≤ w_j                     passivity cuts (optim.robust.passivity): a corner (b, T, n)
                                            and an angle θ_j, u = K_ref·T·s_n(θ_j)/(2b),
                                            v = B_ref·cos((n+1)θ_j)/b, w = 1 (0, 0, 1 pads a slot)

H_s is optim.stiffness.loop's CasADi loop function (the exact ZOH matrices as
parameters).  Solvers are built once per structure (states, crossovers and
Nyquist flag of each scenario) and per thread, Ipopt silent, status always read.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from optim.solver_cache import thread_solver
from optim.stiffness.loop import casadi_loop_function
from optim.stiffness.problem import IPOPT_OPTIONS

__all__ = ["RobustKey", "RobustSolution", "solve_robust", "CUT_BLOCK", "cut_slots"]

_GLOBAL = 5                           # g, K_ref, B_ref, K_cap, B_cap
#: passivity cut slots come in blocks of this many, so a few new cuts do not build a new solver each time
CUT_BLOCK = 8


def cut_slots(n_cuts: int) -> int:
    """Slots for n_cuts passivity cuts (0 when none)."""
    return -(-n_cuts // CUT_BLOCK) * CUT_BLOCK


@dataclass(frozen=True)
class RobustKey:
    n_states: int
    scenarios: tuple[tuple[int, bool], ...]
    """(tracked interior crossovers, Nyquist constraint) of each scenario, in parameter order."""
    cuts: int = 0
    """passivity cut slots (a multiple of CUT_BLOCK; unused slots are padded)."""


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
    p = ca.SX.sym("p", _GLOBAL + len(key.scenarios) * (nl + 2) + 3 * key.cuts)
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
    for j in range(key.cuts):
        u, v, w = p[off + 3 * j], p[off + 3 * j + 1], p[off + 3 * j + 2]
        ineqs.append(k * u - b * v - w)
    name = ("robust_" + str(n) + "_" + "_".join(f"{m}{int(q)}" for m, q in key.scenarios)
            + (f"_c{key.cuts}" if key.cuts else ""))
    return ca.nlpsol(name, "ipopt", {"x": x, "p": p, "f": -k, "g": ca.vertcat(*(eqs + ineqs))},
                     {**IPOPT_OPTIONS, "calc_lam_p": False})


def _solver(key: RobustKey) -> ca.Function:
    return thread_solver("robust-stiffness", key, lambda: _build(key))


def solve_robust(key: RobustKey, global_params: np.ndarray, scenario_params: list[np.ndarray], x0: np.ndarray,
                 b_bounds: tuple[float, float], theta_bounds: list[tuple[float, float]],
                 cut_params: np.ndarray | None = None) -> RobustSolution:
    """Solve with the scenarios' parameters ([loop flat, m/T², m/T] each) in the key's order, and the passivity
    cuts' rows (u, v, w) (at most key.cuts; the rest are padded)."""
    solver = _solver(key)
    m_total = sum(m for m, _ in key.scenarios)
    n_ineq = m_total + sum(int(q) for _, q in key.scenarios) + 2 + key.cuts
    cuts = np.zeros((key.cuts, 3))
    cuts[:, 2] = 1.0                                       # a padded slot reads 0 ≤ 1
    if cut_params is not None and len(cut_params):
        rows = np.asarray(cut_params, float).reshape(-1, 3)
        if rows.shape[0] > key.cuts:
            raise ValueError(f"{rows.shape[0]} passivity cuts for {key.cuts} slots")
        cuts[:rows.shape[0]] = rows
    params = np.concatenate([global_params, *scenario_params, cuts.ravel()])
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
