"""Safeguards of the stiffness design's search (issue 17): seeds per interval, stalled Ipopt iterates, the exact
B scan when Ipopt fails, the exact profile behind an "infeasible", and the passive profile at long delays.

Each works on the exact analysis (optim.stability.margins, optim.stability.passivity), never on the coarse interpolation alone.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from scipy.optimize import minimize_scalar

from optim.stability.margins import critical_stiffness
from optim.stability.passivity import largest_passive_stiffness, passive_alpha_on_grid
from optim.stiffness.problem import ProblemKey, ProblemSolution

if TYPE_CHECKING:
    from optim.stiffness.design import DesignAttempt, DesignContext

__all__ = ["starts", "value", "settled", "ipopt_ok", "locally_optimal", "scan_attempt", "exact_profile",
           "passive_profile", "passive_beta_bound"]

MAX_STARTS = 6
#: Ipopt statuses whose iterate is kept: it stalls a hair from the optimum when its 1e-11 tolerance is below the
#: noise of the crossover equations (seen on lightly damped cables at long delays).  The exact re-check makes
#: the point feasible, and ``_locally_optimal`` tests it before it is labelled optimal.
STUCK = ("Search_Direction_Becomes_Too_Small", "Solved_To_Acceptable_Level")


def ipopt_ok(at: DesignAttempt) -> bool:
    return at.sol.success or at.sol.return_status in STUCK


def settled(at: DesignAttempt) -> bool:
    return ipopt_ok(at) and at.converged


def exact_objective(ctx: DesignContext, b: float) -> float:
    """min(g·K_cr(B), passive K(B), caps) [N/m] from the exact analysis."""
    k = ctx.req.gain_factor * critical_stiffness(ctx.device, b, b_max=ctx.b_max).critical_stiffness
    if ctx.req.passivity:
        k = min(k, largest_passive_stiffness(ctx.device, b).stiffness)
    return min([k, *ctx.req.stiffness_caps().values()])


def locally_optimal(ctx: DesignContext, at: DesignAttempt) -> bool:
    """A stalled Ipopt iterate is kept only if the exact objective at B ± 1e-4 of the B range does not beat it."""
    if at.sol.success:
        return True
    best = value(ctx, at)
    h = 1e-4 * ctx.beta_hi * ctx.device.damping_scale
    upper = ctx.beta_hi * ctx.device.damping_scale
    for b in (at.damping - h, at.damping + h):
        if 0.0 <= b < upper and exact_objective(ctx, b) > best * (1 + 1e-7):
            return False
    return True


def starts(ctx: DesignContext, betas: np.ndarray, objective: np.ndarray) -> list[int]:
    """Seeds in decreasing coarse objective, one per interval between the curve's breakpoints.

    The coarse profile interpolates the sampled curve: next to a fold it can miss a crossover that is about to
    vanish and overstate the objective there (a cable with b_c = 192 N·s/m seeded at the fold's low side gave
    16 N/m where 9,084 N/m was reachable across it).  Every interval whose seed beats the verified answer is
    solved, up to MAX_STARTS."""
    pts = np.array([0.0, *ctx.curve.breakpoints, np.inf])
    which = np.searchsorted(pts, betas, side="right")
    best: dict[int, int] = {}
    for j in np.argsort(-objective, kind="stable"):
        if objective[j] > 0 and int(which[j]) not in best:
            best[int(which[j])] = int(j)
    return sorted(best.values(), key=lambda j: -objective[j])[:MAX_STARTS]


def value(ctx: DesignContext, at: DesignAttempt) -> float:
    """The design K [N/m] an attempt gives (before the back-off): −inf unless Ipopt converged and settled."""
    if not settled(at):
        return -math.inf
    ks = [at.stiffness, ctx.req.gain_factor * at.exact.critical_stiffness, *ctx.req.stiffness_caps().values()]
    if at.passive_k is not None:
        ks.append(at.passive_k)
    return min(ks)


#: zoom refinement of the exact B scan: points per bracket and rounds (each round shrinks the bracket to two of
#: its steps, a factor (ZOOM_POINTS + 1)/2 = 5; 8 rounds take it to 2.6e-6 of itself, where Brent polishes)
ZOOM_POINTS = 9
ZOOM_ROUNDS = 8


def _zoom(f, lo: float, hi: float, x0: float, f0: float) -> tuple[float, float]:
    """The largest f on [lo, hi] by nested grids around the best point so far.

    The exact objective min(g·K_cr, passive K, caps) is 0 wherever no K is passive: its peak can sit next to a
    plateau of zeros (a cable with b = 7.8e-6 N·s/m and 71 samples of delay is passive only for B < 7.8e-6 of a
    9.5e-3 N·s/m range), where bounded Brent, comparing equal zeros, stopped at the bracket's grid point 1.8 %
    below the peak (issue 17).  A grid does not need the function to be unimodal: it keeps the best sample and
    shrinks around it."""
    best_x, best_f = x0, f0
    for _ in range(ZOOM_ROUNDS):
        if not hi > lo:
            break
        xs = np.linspace(lo, hi, ZOOM_POINTS + 2)
        vals = [f0 if x == best_x else f(float(x)) for x in xs]
        i = int(np.argmax(vals))
        if vals[i] > best_f:
            best_x, best_f = float(xs[i]), float(vals[i])
        i = int(np.argmin(np.abs(xs - best_x)))
        lo, hi = float(xs[max(i - 1, 0)]), float(xs[min(i + 1, xs.size - 1)])
        f0 = best_f
    return best_x, best_f


def scan_attempt(ctx: DesignContext, like: DesignAttempt | None, seeds: tuple[float, ...] = ()) -> DesignAttempt:
    """Maximise the exact objective min(g·K_cr(B), passive K(B), caps) over B: the exact profile (plus ``seeds``,
    dimensionless β's the coarse profile or Ipopt found good), then nested grids around its three best points, and
    bounded Brent inside the final bracket (the peak of a smooth piece to the last bits)."""
    betas, obj, _ = exact_profile(ctx, 49)
    dev, bs, ks = ctx.device, ctx.device.damping_scale, ctx.device.stiffness_scale

    def f(beta: float) -> float:
        if not 0.0 <= beta <= ctx.beta_hi:
            return -math.inf
        b = beta * bs
        a = ctx.req.gain_factor * critical_stiffness(dev, b, b_max=ctx.b_max).critical_stiffness / ks
        if ctx.req.passivity:
            a = min(a, largest_passive_stiffness(dev, b).stiffness / ks)
        return min(a, ctx.alpha_cap)
    extra = np.array([s for s in seeds if 0.0 <= s < ctx.beta_hi and not np.any(betas == s)])
    if extra.size:
        betas = np.concatenate([betas, extra])
        obj = np.concatenate([obj, [f(float(s)) for s in extra]])
        order = np.argsort(betas)
        betas, obj = betas[order], obj[order]
    best_a, best_b = float(obj.max()), float(betas[int(obj.argmax())])
    for i in np.argsort(-obj)[:3]:
        if not obj[i] > 0.0:
            break
        lo, hi = betas[max(i - 1, 0)], betas[min(i + 1, betas.size - 1)]
        x, v = _zoom(f, float(lo), float(hi), float(betas[i]), float(obj[i]))
        step = (hi - lo) / ((ZOOM_POINTS + 1) / 2.0) ** ZOOM_ROUNDS
        res = minimize_scalar(lambda t: -f(t), bounds=(max(lo, x - 2 * step), min(hi, x + 2 * step)),
                              method="bounded", options={"xatol": 1e-3 * step})
        if -res.fun > v:
            x, v = float(res.x), float(-res.fun)
        if v > best_a:
            best_a, best_b = v, x
    b = best_b * bs
    exact = critical_stiffness(dev, b, b_max=ctx.b_max)
    pk = largest_passive_stiffness(dev, b).stiffness if ctx.req.passivity else None
    sol = ProblemSolution(True, "exact B scan", 0, best_a, best_b, (), np.zeros(0), np.zeros(0), np.zeros(0))
    key = like.key if like is not None else ProblemKey(ctx.n_states, 0, False, 0)
    from optim.stiffness.design import DesignAttempt

    return DesignAttempt(sol, key, np.zeros(0), 1.0, 1.0, (0.0, ctx.beta_hi), best_a * ks, b, exact, pk, True)


_PASSIVE_WORK = 4_000_000     # β's × θ samples of one passive_alpha_on_grid call


def passive_profile(delta: float, d: int, betas: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """passive_alpha_on_grid on the sorted β's, on a subset of them when the kernel's θ grid is long.

    Its grid has 64·(d+1) samples: at 3,000 samples of delay and ~460 β's that was 97 M entries and 30 s.
    The passive α(β) is a minimum of functions affine in β (concave where positive), so interpolating
    it between subset points errs low: a seed, as before; the exact passivity check decides."""
    n_theta = 64 * (d + 1) + 257
    if betas.size * n_theta <= _PASSIVE_WORK:
        return passive_alpha_on_grid(delta, d, betas)
    m = max(8, _PASSIVE_WORK // n_theta)
    pick = np.unique(np.linspace(0, betas.size - 1, m).round().astype(int))
    sub = betas[pick]
    pa, th = [], []
    for chunk in np.array_split(sub, max(1, sub.size * n_theta // _PASSIVE_WORK)):
        a, t = passive_alpha_on_grid(delta, d, chunk)
        pa.append(a)
        th.append(t)
    pa, th = np.concatenate(pa), np.concatenate(th)
    near = pick[np.clip(np.searchsorted(sub, betas), 0, sub.size - 1)]
    return np.interp(betas, sub, pa), th[np.searchsorted(pick, near)]


def passive_beta_bound(ctx: DesignContext) -> float:
    """A dimensionless β above which no K > 0 is passive (the passive band of B), capped at the B range.

    P(θ) = (K·T/2)·s_d(θ) − B·cos((d+1)θ) < b: at θ = π it reads (−1)^d·(K·T/2 + B) < b, so B < b for even d; where
    s_d vanishes (θ_k = 2πk/(2d+1)) it reads −B·cos((d+1)θ_k) < b, and for k = 1 that is B < b/cos(π/(2d+1)).
    With b ≪ B_max (δ ~ 1e-9) the band is a few 1e-4 of the B range: grids over [0, B_max] step over it."""
    b = ctx.device.damping
    bound = b if ctx.d_pass == 0 else b / math.cos(math.pi / (2 * ctx.d_pass + 1))
    return min(ctx.beta_hi, bound / ctx.device.damping_scale * (1 + 1e-9))


def exact_profile(ctx: DesignContext, points: int = 33) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The objective of ``_coarse_profile`` from the exact analysis (optim.stability.margins, optim.stability.passivity) at a few β:
    evenly spaced, next to B_max, and log-spaced near 0 (a passive wall needs B of the order of b, often ≪ B_max:
    at m = 5.4 kg, b = 3.5 N·s/m, 2 samples of delay the passive optimum is at B = 2.65 of a 2,896 N·s/m range)."""
    hi = ctx.beta_hi
    betas = np.unique(np.concatenate([np.linspace(0.0, hi, points)[:-1], hi * (1 - np.geomspace(1e-6, 1e-2, 3)),
                                      hi * np.geomspace(1e-7, 1.0 / points, 12)]))
    if ctx.req.passivity:
        # every passive wall has B below the bound: the profile is spent there (issue 17: a cable passive only for
        # B < 7.8e-6 of a 9.5e-3 N·s/m range had 1 point of 63 in its band)
        band = passive_beta_bound(ctx)
        betas = np.unique(np.concatenate([np.linspace(0.0, band, points + 1),
                                          band * np.geomspace(1e-7, 1.0 / points, 12)]))
    dev, bs, ks = ctx.device, ctx.device.damping_scale, ctx.device.stiffness_scale
    obj, theta = np.zeros(betas.size), np.zeros(betas.size)
    for j, beta in enumerate(betas):
        b = float(beta) * bs
        a = ctx.req.gain_factor * critical_stiffness(dev, b, b_max=ctx.b_max).critical_stiffness / ks
        if ctx.req.passivity:
            pk = largest_passive_stiffness(dev, b)
            a = min(a, pk.stiffness / ks)
            theta[j] = pk.worst_angle or 0.0
        obj[j] = min(a, ctx.alpha_cap)
    return betas, obj, theta
