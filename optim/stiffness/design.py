"""The stiffest safe wall: maximise K over (K, B) on the exact sampled-data boundary.

Steps (each a function below):
1. the boundary curve θ ↦ (β_c, α_c) is sampled and cut where crossovers are born
   or die (profile.py); a coarse profile of the objective on β picks the interval
   and seeds every crossover angle;
2. the CasADi NLP (problem.py) maximises α on that interval with the tracked
   crossovers, the Nyquist crossover, the limits and passivity cuts;
3. the answer is re-checked by the exact analysis (optim.stability.margins.critical_stiffness
   at the chosen B, and the passivity scan): a crossover or passivity angle the NLP
   did not know about is added and the NLP solved again (an exchange method);
4. the optimum's sensitivities to the device come from Ipopt's multipliers
   (lam_p = ∂L/∂p, the envelope theorem) chained with ∂p/∂(device) (sensitivity.py).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from models.device import Device
from optim.solver_info import NO_SOLVER, SolverInfo
from optim.stability.margins import critical_stiffness, gain_margin_db, linear_estimate, max_stable_damping
from optim.stability.passivity import kernel, largest_passive_stiffness, passivity_margin, passivity_samples
from optim.stiffness import safeguards
from optim.stiffness.loop import loop_matrices
from optim.stiffness.problem import N_CUTS, ProblemKey, ProblemSolution, solve_problem
from optim.stiffness.profile import BoundaryCurve, boundary_curve, coarse_critical, crossings_at
from optim.stiffness.rendered_filter import RenderedFilter
from optim.stiffness.requirements import DESIGN_BACK_OFF, StiffnessRequirements

__all__ = ["StiffnessDesign", "Sensitivity", "design_stiffness", "DesignContext", "DesignAttempt", "problem_params"]

_MAX_EXCHANGES = 16
_PASSIVITY_RTOL = 1e-7   # cutting planes converge linearly at a smooth passivity optimum: stop here, then clip
_VERIFY_RTOL = 1e-8          # an NLP optimum may exceed the exact bound by this much before we re-solve
_ACTIVE_RTOL = 1e-6
_SEED_RTOL = 1e-7            # an Ipopt answer this far below the exact objective at a seed is not taken as optimal


@dataclass(frozen=True)
class Sensitivity:
    """dK*/d(parameter) of the optimal design, re-optimised (B moves too)."""

    parameter: str
    derivative: float
    """dK*/dq [N/m per SI unit of q]."""
    step: float
    """a designer's step of q [SI unit]."""
    step_label: str
    change: float
    """derivative · step [N/m]."""
    statement: str


@dataclass(frozen=True)
class StiffnessDesign:
    status: Literal["optimal", "infeasible", "failed", "unsafe"]
    """unsafe: a design of an approximate rung (linear, grid) that fails its own exact check (optim.design_ladder)."""
    stiffness: float | None = None
    """K [N/m]."""
    damping: float | None = None
    """B [N·s/m]."""
    critical_stiffness: float | None = None
    """exact K_cr(B) at the chosen B [N/m]."""
    gain_margin_db: float | None = None
    """exact 20·log10(K_cr(B)/K) [dB]."""
    crossover_frequency: float | None = None
    """ω [rad/s] of the crossover that sets K_cr(B)."""
    linear_estimate: float | None = None
    """eq. 10 at the chosen B: (b + B)/(T/2 + t_d) [N/m]."""
    linear_estimate_error: float | None = None
    """(linear − exact)/exact K_cr at the chosen B."""
    max_stable_damping: float | None = None
    """B_max [N·s/m]."""
    active_constraints: tuple[str, ...] = ()
    """limits within 1e-6 (relative) of binding K or B."""
    back_off: float | None = None
    """K sits at least this far (relative) below g·K_cr(B) and the passive K(B), the limits the analysis checks
    (DESIGN_BACK_OFF; caps on K are met as K ≤ cap); None on the rungs that do not apply it."""
    sensitivities: tuple[Sensitivity, ...] = ()
    sensitivity_note: str | None = None
    passivity_delay_samples: int | None = None
    passivity_note: str | None = None
    reason: str | None = None
    rendered: RenderedFilter | None = None
    """the velocity filter (given or designed), virtual mass and damper noise of a rendered wall; None for today's
    wall C(z) = K + B(1 − z⁻¹)/T."""
    solver: SolverInfo = NO_SOLVER
    """the method that answered (Ipopt, the exact B scan fallback, or a rung's own), how it ended, its structure."""
    elapsed_ms: float = 0.0
    setup_ms: float = 0.0
    solve_ms: float = 0.0


@dataclass
class DesignContext:
    """One design's device, requirements and boundary curve in dimensionless form (shared with safeguards.py and
    sensitivity.py)."""

    device: Device
    req: StiffnessRequirements
    curve: BoundaryCurve
    beta_hi: float
    alpha_cap: float
    beta_cap: float
    d_pass: int
    loop_flat: np.ndarray
    n_states: int
    b_max: float
    """B_max of the device [N·s/m] (passed to every exact re-check instead of recomputed)."""


def _infeasible(reason: str, t0: float, **kw) -> StiffnessDesign:
    return StiffnessDesign(status="infeasible", reason=reason, elapsed_ms=(time.perf_counter() - t0) * 1e3, **kw)


def design_stiffness(device: Device, requirements: StiffnessRequirements | None = None) -> StiffnessDesign:
    """The largest K (and its B) with the required gain margin and limits, on the exact boundary."""
    t0 = time.perf_counter()
    req = requirements or StiffnessRequirements()
    ks, bs = device.stiffness_scale, device.damping_scale
    k_caps, b_caps = req.stiffness_caps(), req.damping_caps(device.sample_time)
    k_caps.update(req.quantization_caps(device.encoder_resolution, device.coulomb_friction))
    if k_caps.get("passive_with_quantization", 1.0) <= 0.0:
        return _infeasible("no quantised wall is passive without Coulomb friction: K ≤ 2f_c/q = 0 (Abbott & Okamura "
                           "2005)", t0)
    b_cap = min(b_caps.values(), default=math.inf)
    k_cap = min(k_caps.values(), default=math.inf)
    d_pass, conservative = passivity_samples(device)
    pass_note = None
    if req.passivity:
        pass_note = (f"passivity tested with {d_pass} whole samples of delay"
                     + (" (the fractional delay rounded up: conservative)" if conservative else ""))
        if device.damping <= 0.0:
            return _infeasible("passivity is impossible on this device: it has no physical damping (b = 0), and a "
                               "passive wall needs b > P(θ) ≥ 0 at some θ for every K > 0 and B ≥ 0; without "
                               "passivity, virtual damping B can still stabilise a wall", t0,
                               passivity_delay_samples=d_pass, passivity_note=pass_note)
    b_max = max_stable_damping(device)
    if not b_max > 0.0:
        return _infeasible("no positive stiffness is stable for any virtual damping on this device", t0,
                           max_stable_damping=_fin(b_max))
    upper_b = min(b_max, b_cap)
    if not math.isfinite(upper_b):
        return _infeasible("the damper-only loop is stable for every B and no max_damping was given: "
                           "the design is unbounded in B", t0)
    beta_hi = upper_b / bs
    curve = boundary_curve(device, beta_hi)
    matrices = loop_matrices(device)
    ctx = DesignContext(device, req, curve, beta_hi, k_cap / ks if math.isfinite(k_cap) else 1e30,
                   b_cap / bs if math.isfinite(b_cap) else 1e30, d_pass, matrices.flat(), matrices.n, b_max)
    betas, objective, pass_theta = _coarse_profile(ctx)
    i = int(np.argmax(objective))
    if not objective[i] > 0.0:
        # the coarse profile is a seed, not a proof: "infeasible" rests on the exact analysis
        betas, objective, pass_theta = safeguards.exact_profile(ctx)
        i = int(np.argmax(objective))
    if not objective[i] > 0.0:
        why = ("passivity and the gain margin leave no positive stiffness for any B in [0, "
               f"{upper_b:.6g}] N·s/m" if req.passivity else
               f"no positive stiffness meets the gain margin for any B in [0, {upper_b:.6g}] N·s/m")
        why += f" (the exact K_cr{' and passivity' if req.passivity else ''} at {betas.size} values of B confirm it)"
        return _infeasible(why, t0, max_stable_damping=_fin(b_max), passivity_delay_samples=d_pass if req.passivity
                           else None, passivity_note=pass_note)
    if not objective[i] < 1e29:
        return _infeasible("every positive stiffness is stable at this damping and no stiffness limit was given: "
                           "the design is unbounded", t0)
    setup_ms = (time.perf_counter() - t0) * 1e3
    best, first, failures = None, None, 0
    seeds, seed_best = [], 0.0
    for j in safeguards.starts(ctx, betas, objective):
        if best is not None and not objective[j] > safeguards.value(ctx, best) / ks * (1 + 1e-6):
            break                 # no other interval's seed can beat the verified answer
        at = _solve_from(ctx, float(betas[j]), float(objective[j]), pass_theta[j])
        first = first or at
        # the seed is a feasible point of the exact problem: an answer below it is not the optimum
        seeds.append(float(betas[j]))
        seed_best = max(seed_best, safeguards.exact_objective(ctx, float(betas[j]) * bs))
        v = safeguards.value(ctx, at)
        if v > 0 and (best is None or v > safeguards.value(ctx, best)) and safeguards.locally_optimal(ctx, at):
            best = at
        failures += not safeguards.settled(at)
        if failures >= 2:
            break
    fallback = None
    if best is None:
        # Ipopt failed on every start (seen with passivity at long delays, where the kernel has ~d local maxima,
        # and on undamped cables): the 1-D problem in B is solved on the exact analysis instead
        best = safeguards.scan_attempt(ctx, first, tuple(seeds))
        fallback = f"Ipopt did not converge ({first.sol.return_status if first else 'no start'}) from any seed"
    elif seed_best > safeguards.value(ctx, best) * (1 + _SEED_RTOL):
        # Ipopt ended below the exact objective at one of its own seeds (a local optimum, or a point the passivity
        # cuts or crossover exchange settled on early): it is not the optimum, so the exact scan decides
        v_ipopt = safeguards.value(ctx, best)
        scan = safeguards.scan_attempt(ctx, best, tuple(seeds) + (best.damping / bs,))
        if safeguards.value(ctx, scan) > v_ipopt:
            best = scan
            fallback = (f"Ipopt's optimum K = {v_ipopt:.6g} N/m is below the exact objective at its seed, "
                        f"{seed_best:.6g} N/m")
    solve_ms = (time.perf_counter() - t0) * 1e3 - setup_ms
    return _finish(ctx, best, b_max, k_caps, b_caps, pass_note, t0, setup_ms, solve_ms, fallback)


def _fin(x: float | None) -> float | None:
    return x if x is not None and math.isfinite(x) else None


def _coarse_profile(ctx: DesignContext) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Objective min(g·K_cr, passive K, caps)/(m/T²) on a β grid that includes the curve's vertices."""
    hi = ctx.beta_hi
    inside = ctx.curve.beta[(ctx.curve.beta > 0) & (ctx.curve.beta < hi)]
    # with passivity, no K > 0 is passive above the passive band of B, which may be ≪ the B range: seed inside it
    band = np.linspace(0.0, safeguards.passive_beta_bound(ctx), 41) if ctx.req.passivity else np.zeros(0)
    betas = np.unique(np.concatenate([np.linspace(0.0, hi, 161)[:-1], hi * (1 - np.geomspace(1e-6, 1e-2, 5)),
                                      inside[:: max(1, inside.size // 300)], np.array(ctx.curve.breakpoints), band]))
    betas = betas[(betas >= 0) & (betas <= hi * (1 - 1e-9))]
    obj = ctx.req.gain_factor * coarse_critical(ctx.curve, betas)
    if ctx.device.delta <= 0.0:
        # b = 0: at B = 0 the loop is a bare double integrator, K_cr = 0 (optim.stability.margins); the curve's lowest
        # crossover θ ≈ sqrt(β/(d+½)) → 0 with α → 0 there, below any sampled θ, so the profile must be told
        obj[betas <= 0.0] = 0.0
    obj = np.minimum(obj, ctx.alpha_cap)
    theta = np.zeros_like(betas)
    if ctx.req.passivity:
        pa, theta = safeguards.passive_profile(ctx.device.delta, ctx.d_pass, betas)
        obj = np.minimum(obj, pa)
    return betas, obj, theta


def _interval(ctx: DesignContext, beta: float) -> tuple[float, float]:
    pts = [0.0] + [b for b in ctx.curve.breakpoints] + [ctx.beta_hi]
    lo = max(p for p in pts if p <= beta)
    hi = min(p for p in pts if p > beta) if any(p > beta for p in pts) else ctx.beta_hi
    width = hi - lo
    # stay a hair inside a fold: exactly at it the vanishing pair of crossovers still counts
    lo2 = lo + 1e-9 * width if lo > 0.0 else 0.0
    hi2 = hi - 1e-9 * width
    return lo2, hi2


@dataclass
class DesignAttempt:
    """One NLP solve from one seed, with its exact re-check (shared with safeguards.py and sensitivity.py)."""

    sol: ProblemSolution
    key: ProblemKey
    params: np.ndarray
    alpha_ref: float
    beta_ref: float
    interval: tuple[float, float]
    stiffness: float
    damping: float
    exact: object
    passive_k: float | None
    converged: bool


def problem_params(ctx: DesignContext, flat: np.ndarray, delta: float, alpha_cap: float, beta_cap: float,
            alpha_ref: float, beta_ref: float, cuts: list[float]) -> np.ndarray:
    s = np.zeros(N_CUTS if ctx.req.passivity else 0)
    c = np.zeros_like(s)
    if cuts:
        ss, cc = kernel(np.array(cuts[-N_CUTS:]), ctx.d_pass)
        s[:ss.size], c[:cc.size] = ss, cc
    return np.concatenate([flat, [ctx.req.gain_factor, alpha_ref, beta_ref, alpha_cap, beta_cap, delta], s, c])


def _piece_bounds(ctx: DesignContext, theta: float) -> tuple[float, float]:
    for p in ctx.curve.pieces:
        lo, hi = min(p.theta_lo, p.theta_hi), max(p.theta_lo, p.theta_hi)
        if lo <= theta <= hi:
            return lo, hi
    return max(theta * 0.5, 1e-9), min(math.pi, theta * 1.5)


def _solve_from(ctx: DesignContext, beta0: float, alpha0: float, pass_theta0: float) -> DesignAttempt:
    interval = _interval(ctx, beta0)
    if ctx.device.delta <= 0.0 and interval[0] <= 0.0:
        # b = 0: as β → 0 the lowest crossover runs to θ → 0 with α → 0, a degenerate corner (Im H/|H| → 0
        # along it) where Ipopt stalls; there K_cr ≈ 2β/(1+2d) ≪ α0, so the optimum is not below 1e-3·β0
        interval = (1e-3 * beta0, interval[1])
    beta_ref = max(beta0, 1e-2 * ctx.beta_hi)
    alpha_ref = alpha0
    # crossovers far above the objective cannot bind nearby; the exact re-check adds any that do
    far = 50.0 * alpha0 / ctx.req.gain_factor
    crossings = [(t, _piece_bounds(ctx, t)) for t, a in crossings_at(ctx.curve, beta0, with_alpha=True) if a <= far]
    # passivity cuts: the binding angle of the coarse profile, the kernel's zeros (they bound B alone) and π
    cuts = [2 * math.pi * k / (2 * ctx.d_pass + 1) for k in range(1, min(ctx.d_pass, N_CUTS - 2) + 1)]
    cuts = [math.pi] + cuts + [float(pass_theta0)] if ctx.req.passivity else []
    dev, ks, bs = ctx.device, ctx.device.stiffness_scale, ctx.device.damping_scale
    x_start = [alpha0 / alpha_ref, beta0 / beta_ref]
    attempt = None
    for _ in range(_MAX_EXCHANGES):
        nyq = float(ctx.curve.nyquist_alpha(np.array([beta0]))[0])
        nyquist = bool(0 < nyq <= far)
        key = ProblemKey(ctx.n_states, len(crossings), nyquist, N_CUTS if ctx.req.passivity else 0)
        params = problem_params(ctx, ctx.loop_flat, dev.delta, ctx.alpha_cap, ctx.beta_cap, alpha_ref, beta_ref,
                                cuts)
        x0 = np.array(x_start + [t for t, _ in crossings])
        sol = solve_problem(key, params, x0, (interval[0] / beta_ref, interval[1] / beta_ref), [b for _, b in crossings])
        k, b = sol.a * alpha_ref * ks, max(sol.b * beta_ref * bs, 0.0)   # Ipopt may relax a bound by ~1e-8
        exact = critical_stiffness(dev, b, b_max=ctx.b_max)
        pk = largest_passive_stiffness(dev, b) if ctx.req.passivity else None
        attempt = DesignAttempt(sol, key, params, alpha_ref, beta_ref, interval, k, b, exact,
                                pk.stiffness if pk else None, False)
        if not (sol.success or sol.return_status in safeguards.STUCK):
            return attempt
        changed = False
        g_k = ctx.req.gain_factor * exact.critical_stiffness
        if k > g_k * (1 + _VERIFY_RTOL) and exact.crossover_frequency is not None:
            th = exact.crossover_frequency * dev.sample_time
            if th < math.pi * (1 - 1e-9) and all(abs(th - t) > 1e-7 * th for t, _ in crossings):
                crossings = [(t, bb) for t, bb in crossings] + [(th, _piece_bounds(ctx, th))]
                changed = True
        if pk is not None and k > pk.stiffness * (1 + _PASSIVITY_RTOL):
            # the semi-infinite constraint's most violated angle at the NLP point becomes a new cut
            check = passivity_margin(dev, k, b)
            if check.worst_angle is not None and all(abs(check.worst_angle - c) > 1e-12 for c in cuts):
                cuts.append(float(check.worst_angle))
                changed = True
        if not changed:
            attempt.converged = True
            return attempt
        x_start = [sol.a, sol.b]
        crossings = [(t if i >= len(sol.thetas) else sol.thetas[i], bb) for i, (t, bb) in enumerate(crossings)]
    return attempt


def at_reason(at: DesignAttempt) -> str | None:
    return getattr(at.exact, "reason", None)


def _finish(ctx: DesignContext, at: DesignAttempt, b_max: float, k_caps: dict, b_caps: dict, pass_note: str | None,
            t0: float, setup_ms: float, solve_ms: float, fallback: str | None = None) -> StiffnessDesign:
    from optim.stiffness.sensitivity import sensitivities

    dev, req = ctx.device, ctx.req
    solver = SolverInfo("ipopt", at.sol.return_status, at.sol.iterations, details=(
        ("structure", {"states": at.key.n_states, "crossovers": at.key.n_crossovers,
                       "nyquist": at.key.nyquist, "passivity_cuts": at.key.cuts}),))
    if fallback is not None:
        solver = SolverInfo("exact B scan", details=(
            ("why", fallback),
            ("method", "the exact objective min(g·K_cr(B), passive K(B), caps) at 63 values of B (even, "
                       "log-spaced near 0, next to B_max) and at the coarse profile's seeds, then nested grids "
                       "and bounded Brent around the three best (optimal to the scan's resolution in B)")))
    def design(**answer: Any) -> StiffnessDesign:
        """The answer with what every outcome of this attempt shares (B_max, the passivity delay, the solver)."""
        return StiffnessDesign(max_stable_damping=_fin(b_max),
                               passivity_delay_samples=ctx.d_pass if req.passivity else None,
                               passivity_note=pass_note, solver=solver, setup_ms=setup_ms, solve_ms=solve_ms,
                               elapsed_ms=(time.perf_counter() - t0) * 1e3, **answer)
    if not safeguards.settled(at):
        why = (f"Ipopt did not converge: {at.sol.return_status}" if not safeguards.ipopt_ok(at) else
               "the exchange of crossovers and passivity angles did not settle")
        return design(status="failed", reason=why)
    kcr = at.exact.critical_stiffness
    analysed = [req.gain_factor * kcr] + ([at.passive_k] if at.passive_k is not None else [])
    k = min([at.stiffness, *k_caps.values(), (1.0 - DESIGN_BACK_OFF) * min(analysed)])
    if not k > 0:
        why = (at_reason(at) or "no positive stiffness satisfies the requirements")
        return design(status="infeasible", reason=why)
    active = []
    if k >= req.gain_factor * kcr * (1 - _ACTIVE_RTOL):
        active.append("min_gain_margin_db")
    if at.passive_k is not None and k >= at.passive_k * (1 - _ACTIVE_RTOL):
        active.append("passivity")
    active += [name for name, cap in k_caps.items() if k >= cap * (1 - _ACTIVE_RTOL)]
    active += [name for name, cap in b_caps.items() if at.damping >= cap * (1 - _ACTIVE_RTOL)]
    if fallback is None and at.sol.success:
        sens, note = sensitivities(ctx, at)
    elif fallback is None:
        sens, note = (), (f"no sensitivities: Ipopt stalled ({at.sol.return_status}) next to the optimum (kept after "
                          "an exact check at B ± 1e-4 of the B range), and its multipliers are not trusted")
    else:
        sens, note = (), "no sensitivities: the design comes from the exact B scan, which has no multipliers"
    lin = linear_estimate(dev, at.damping)
    return design(
        status="optimal", stiffness=k, damping=at.damping, critical_stiffness=kcr,
        gain_margin_db=gain_margin_db(kcr, k), crossover_frequency=at.exact.crossover_frequency,
        linear_estimate=lin, linear_estimate_error=(lin - kcr) / kcr, active_constraints=tuple(active),
        back_off=DESIGN_BACK_OFF, sensitivities=sens, sensitivity_note=note)
