"""The stiffest wall with a designed low-pass cutoff: one CasADi NLP in (K, B, cutoff) on the exact loop.

The wall is C(z) = K + B·V(z; f) + M·A(z; f) with V the backward difference followed by a unit-DC low-pass of
cutoff f (models.velocity_filter): order 1 step-invariant, L = (1 − a)/(1 − a w), a = exp(−2πν); order 2 the
Butterworth by the bilinear transform prewarped at f, L = Ω²(1 + w)²/(c₀ + c₁w + c₂w²), Ω = tan(πν),
c₀ = 1 + √2Ω + Ω², c₁ = 2(Ω² − 1), c₂ = 1 − √2Ω + Ω²; w = e^{−jθ}, ν = f·T.  Both depend on ν alone.

Decision variables (scaled): a = α/α_ref, b = β/β_ref, c = ln(ν/ν_ref), one angle θ_i per tracked crossover.

    Im h(θ_i)/|h| = 0,  α ≤ g·Re h(θ_i)      h = −1/G_n − β·V_n − μ·A_n (optim.stability.rendered's h_K)
    α ≤ g·h(π)                               the Nyquist crossover (h(π) is real for every β, ν)
    α ≤ α_cap,  β ≤ β_cap                    stiffness and damping limits of the request
    β·S_n(ν) ≤ σ_step,  β·N_n(ν) ≤ σ_rms     the noise rules (models.velocity_noise), dimensionless
    P_j(α, β, ν) ≤ δ                         passivity cuts at fixed angles (general Colgate–Schenkel)
    α·(d + ½) − β ≤ δ                        passivity as θ → 0⁺

S_n = T·max|s_k| and N_n = T·sqrt(Σh_k²) come from B-spline interpolants of their exact values on a log grid of
ν (built once per order): the NLP's noise constraints are that accurate only, so the design re-evaluates every
constraint exactly at the NLP's (B, f) and clips B to the exact noise caps before it computes K.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import casadi as ca
import numpy as np

from models.velocity_filter import LowPass, velocity_transfer
from models.velocity_noise import noise_gain, step_peak
from optim.solver_cache import thread_solver
from optim.stiffness.loop import casadi_inverse_response
from optim.stiffness.problem import IPOPT_OPTIONS

__all__ = ["CutoffKey", "CutoffSolution", "solve_cutoff_problem", "N_CUTS", "NU_MIN", "NU_MAX", "casadi_low_pass"]

N_CUTS = 8
#: ν = f·T range of the noise interpolants (a designed cutoff's band lies inside it)
NU_MIN, NU_MAX = 1e-5, 0.4999
_NO_LIMIT = 1e30
_OPTIONS: dict[str, Any] = {**IPOPT_OPTIONS, "calc_lam_p": False}


@dataclass(frozen=True)
class CutoffKey:
    n_states: int
    order: int
    n_crossovers: int
    nyquist: bool
    cuts: int


@dataclass(frozen=True)
class CutoffSolution:
    success: bool
    return_status: str
    iterations: int
    a: float
    b: float
    c: float
    thetas: tuple[float, ...]


@lru_cache(maxsize=2)
def noise_interpolants(order: int) -> tuple[ca.Function, ca.Function]:
    """ln S_n and ln N_n as functions of ln ν (B-splines through their exact values on 400 log-spaced ν)."""
    nus = np.geomspace(NU_MIN, NU_MAX, 400)
    s, n = [], []
    for nu in nus:
        vt = velocity_transfer(LowPass(kind="low_pass", cutoff_hz=float(nu), order=1 if order == 1 else 2), 1.0)
        s.append(math.log(step_peak(vt, 1.0)))
        n.append(math.log(noise_gain(vt, 1.0)))
    x = [list(np.log(nus))]
    return (ca.interpolant(f"ln_step_{order}", "bspline", x, s),
            ca.interpolant(f"ln_noise_{order}", "bspline", x, n))


def casadi_low_pass(theta, nu, order: int):
    """(Re, Im) of V_n = T·V(e^{jθ}) for the low-pass velocity of cutoff ν = f·T."""
    wr, wi = ca.cos(theta), -ca.sin(theta)                 # w = e^{−jθ}
    dr, di = 2 * ca.sin(theta / 2) ** 2, ca.sin(theta)     # 1 − w, accurate at small θ
    if order == 1:
        a = ca.exp(-2 * math.pi * nu)
        nr, ni = -ca.expm1(-2 * math.pi * nu), 0.0
        qr, qi = 1 - a * wr, -a * wi
    else:
        om = ca.tan(math.pi * nu)
        c0, c1, c2 = 1 + math.sqrt(2) * om + om * om, 2 * (om * om - 1), 1 - math.sqrt(2) * om + om * om
        pr, pi_ = 1 + wr, wi                                 # 1 + w
        nr, ni = om * om * (pr * pr - pi_ * pi_), om * om * 2 * pr * pi_
        w2r, w2i = wr * wr - wi * wi, 2 * wr * wi
        qr, qi = c0 + c1 * wr + c2 * w2r, c1 * wi + c2 * w2i
    q2 = qr * qr + qi * qi
    lr, li = (nr * qr + ni * qi) / q2, (ni * qr - nr * qi) / q2   # L = N/Q
    return dr * lr - di * li, dr * li + di * lr


def n_params(key: CutoffKey) -> int:
    n = key.n_states
    return n * n + 3 * n + 1 + 12 + 2 * key.cuts


def _build(key: CutoffKey) -> ca.Function:
    n, m = key.n_states, key.n_crossovers
    x = ca.SX.sym("x", 3 + m)
    p = ca.SX.sym("p", n_params(key))
    nl = n * n + 3 * n + 1
    loop = p[0:nl]
    g_gain, a_ref, b_ref, a_cap, b_cap, mu, delta, d_pass, nu_ref, s_step, s_rms, half_d = (
        p[nl + k] for k in range(12))
    cut_th = p[nl + 12:nl + 12 + key.cuts]
    a, b, c = x[0], x[1], x[2]
    alpha, beta, nu = a * a_ref, b * b_ref, nu_ref * ca.exp(c)
    ln_step, ln_noise = noise_interpolants(key.order)

    def h(theta):
        ir, ii = casadi_inverse_response(theta, n, loop)
        vr, vi = casadi_low_pass(theta, nu, key.order)
        dr, di = 2 * ca.sin(theta / 2) ** 2, ca.sin(theta)
        ar, ai = vr * dr - vi * di, vr * di + vi * dr            # A_n = V_n·(1 − w)
        return -ir - beta * vr - mu * ar, -ii - beta * vi - mu * ai

    eqs, ineqs = [], []
    for i in range(m):
        hr, hi = h(x[3 + i])
        eqs.append(hi / ca.sqrt(hr * hr + hi * hi))
        ineqs.append(a - g_gain * hr / a_ref)
    if key.nyquist:
        hr, _ = h(ca.DM(math.pi))
        ineqs.append(a - g_gain * hr / a_ref)
    ineqs.append(a - a_cap / a_ref)
    ineqs.append(b - b_cap / b_ref)
    # Ipopt may step a hair outside the bounds (bound_relax_factor): keep the logarithms and the splines' range
    ln_nu = ca.log(ca.fmin(ca.fmax(nu, NU_MIN), NU_MAX))
    ln_beta = ca.log(ca.fmax(beta, 1e-300))
    ineqs.append((ln_beta + ln_step(ln_nu)) - ca.log(s_step))
    ineqs.append((ln_beta + ln_noise(ln_nu)) - ca.log(s_rms))
    for j in range(key.cuts):
        th = cut_th[j]
        vr, vi = casadi_low_pass(th, nu, key.order)
        dr, di = 2 * ca.sin(th / 2) ** 2, ca.sin(th)
        ar, ai = vr * dr - vi * di, vr * di + vi * dr
        cr, ci = beta * vr + mu * ar, beta * vi + mu * ai         # (B·V + M·A)·T²/m without K
        er, ei = ca.cos(d_pass * th), -ca.sin(d_pass * th)       # e^{−jdθ}
        wr_, wi_ = dr * er - di * ei, dr * ei + di * er          # (1 − e^{−jθ})·e^{−jdθ}
        kern = ca.sin(half_d * th) / ca.sin(th / 2)              # s_d(θ) = sin((d + ½)θ)/sin(θ/2)
        bound = alpha * kern / 2 + 0.5 * (wr_ * cr - wi_ * ci) / (2 * ca.sin(th / 2) ** 2)
        ineqs.append((bound - delta) / a_ref)
    if key.cuts:
        ineqs.append((alpha * half_d - beta - delta) / a_ref)
    g = ca.vertcat(*(eqs + ineqs))
    return ca.nlpsol(f"cutoff_{n}_{key.order}_{m}_{int(key.nyquist)}_{key.cuts}", "ipopt",
                     {"x": x, "p": p, "f": -a, "g": g}, _OPTIONS)


def solver_for(key: CutoffKey) -> ca.Function:
    """This thread's solver for the structure (CasADi solvers are not thread-safe: optim.solver_cache)."""
    return thread_solver("cutoff", key, lambda: _build(key))


def cutoff_params(loop_flat: np.ndarray, gain: float, alpha_ref: float, beta_ref: float, alpha_cap: float,
                  beta_cap: float, mu: float, delta: float, d_pass: int, nu_ref: float, sigma_step: float,
                  sigma_rms: float, cuts: list[float], n_cuts: int) -> np.ndarray:
    th = np.full(n_cuts, math.pi)
    if cuts:
        th[:min(len(cuts), n_cuts)] = cuts[-n_cuts:]
    fin = [min(v, _NO_LIMIT) for v in (alpha_cap, beta_cap, sigma_step, sigma_rms)]
    return np.concatenate([loop_flat, [gain, alpha_ref, beta_ref, fin[0], fin[1], mu, delta, float(d_pass), nu_ref,
                                       fin[2], fin[3], d_pass + 0.5], th, np.zeros(n_cuts)])


def solve_cutoff_problem(key: CutoffKey, params: np.ndarray, x0: list[float], c_bounds: tuple[float, float],
                         b_bounds: tuple[float, float],
                         theta_bounds: list[tuple[float, float]]) -> CutoffSolution:
    solver = solver_for(key)
    m = key.n_crossovers
    n_ineq = m + int(key.nyquist) + 4 + key.cuts + int(key.cuts > 0)
    lbx = [0.0, b_bounds[0], c_bounds[0]] + [t[0] for t in theta_bounds]
    ubx = [np.inf, b_bounds[1], c_bounds[1]] + [t[1] for t in theta_bounds]
    out = solver(x0=x0, p=params, lbx=lbx, ubx=ubx, lbg=[0.0] * m + [-np.inf] * n_ineq, ubg=[0.0] * (m + n_ineq))
    stats = solver.stats()
    xs = np.asarray(out["x"]).ravel()
    return CutoffSolution(bool(stats["success"]), str(stats["return_status"]), int(stats.get("iter_count", -1)),
                          float(xs[0]), float(xs[1]), float(xs[2]), tuple(float(v) for v in xs[3:]))
