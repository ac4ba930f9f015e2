"""The stiffest safe rendered wall C(z) = K + B·V(z) + M·A(z): a fixed velocity filter and virtual mass, or a
low-pass whose cutoff is designed with K and B (ARCHITECTURE.md, "The rendered virtual environment").

Fixed filter: the objective min(g·K_cr(B), passive K(B), caps) is maximised over B ∈ [0, min(B_max, B caps)] on
the exact rendered analysis (optim.stability.rendered, optim.stability.passivity_rendered_limit): an exact
profile, nested grids around its three best points, bounded Brent in the last bracket.  The noise rules are caps
on B at a fixed filter (models.velocity_noise).

Designed cutoff: a coarse exact profile over (cutoff, B) seeds the CasADi NLP of optim.stiffness.cutoff_problem
(K, B and the cutoff together, crossovers tracked, passivity cuts, the noise rules); every NLP answer is
re-evaluated exactly (K_cr at its B and cutoff, passivity, noise caps) and crossovers or passivity angles the
NLP missed are added (an exchange method).  The answer's K is always computed from the exact analysis at its
(B, cutoff), so it is feasible by construction; it is labelled optimal only when the exact check agrees and the
NLP's answer is not below the best exact point of the seeding profile.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import minimize_scalar

from models.device import Device
from models.velocity_filter import LowPass, Rendering, rendering, velocity_transfer
from models.velocity_noise import noise_gain, step_peak
from optim.errors import InputError
from optim.solver_info import SolverInfo
from optim.stability.margins import gain_margin_db, linear_estimate
from optim.stability.passivity import passivity_samples
from optim.stability.passivity_rendered_limit import largest_rendered_passive_stiffness
from optim.stability.rendered import rendered_critical_stiffness, rendered_max_stable_damping
from optim.stiffness.cutoff_problem import N_CUTS, CutoffKey, cutoff_params, solve_cutoff_problem
from optim.stiffness.loop import loop_matrices
from optim.stiffness.rendered_filter import RenderedFilter
from optim.stiffness.requirements import DESIGN_BACK_OFF, CutoffDesign, StiffnessRequirements

__all__ = ["RenderedFilter", "design_rendered_stiffness", "fixed_filter_objective", "FILTER_PROFILE_CUTOFFS"]

_ACTIVE_RTOL = 1e-6
#: cutoffs of the coarse (cutoff, B) profile that seeds the NLP
FILTER_PROFILE_CUTOFFS = 13
_B_PROFILE = 13
_MAX_EXCHANGES = 10


@dataclass
class FilterContext:
    device: Device
    req: StiffnessRequirements
    mass: float
    k_caps: dict
    gain: float


def _filter_caps(ctx: FilterContext, rend: Rendering) -> dict[str, float]:
    t = ctx.device.sample_time
    return ctx.req.damping_caps(t, step_peak(rend.velocity, t), noise_gain(rend.velocity, t))


def fixed_filter_objective(ctx: FilterContext, rend: Rendering, b: float) -> tuple[float, float, float | None]:
    """(min(g·K_cr, passive K, caps) [N/m], K_cr [N/m], passive K or None) at B from the exact analysis."""
    kcr = rendered_critical_stiffness(ctx.device, b, rend).critical_stiffness
    k = ctx.gain * kcr
    pk = None
    if ctx.req.passivity:
        pk = largest_rendered_passive_stiffness(ctx.device, b, rend)[0]
        k = min(k, pk)
    return min([k, *ctx.k_caps.values()]), kcr, pk


def _zoom(f, lo: float, hi: float, x0: float, f0: float, rounds: int = 6, points: int = 7,
          polish: bool = True) -> tuple[float, float]:
    """The largest f on [lo, hi] by nested grids around the best point (as optim.stiffness.safeguards._zoom)."""
    best_x, best_f = x0, f0
    for _ in range(rounds):
        if not hi > lo:
            break
        xs = np.linspace(lo, hi, points + 2)
        vals = [best_f if x == best_x else f(float(x)) for x in xs]
        i = int(np.argmax(vals))
        if vals[i] > best_f:
            best_x, best_f = float(xs[i]), float(vals[i])
        i = int(np.argmin(np.abs(xs - best_x)))
        lo, hi = float(xs[max(i - 1, 0)]), float(xs[min(i + 1, xs.size - 1)])
    res = minimize_scalar(lambda t: -f(t), bounds=(lo, hi), method="bounded",
                          options={"xatol": 1e-10 * max(hi, 1e-300)}) if hi > lo and polish else None
    if res is not None and -res.fun > best_f:
        best_x, best_f = float(res.x), float(-res.fun)
    return best_x, best_f


#: the nested-grid + bounded-Brent maximiser, shared with the robust rendered design (optim.robust.rendered_stiffness)
zoom_maximum = _zoom


def _b_range(ctx: FilterContext, rend: Rendering) -> tuple[float, float, dict[str, float], str | None]:
    """(B_max, the largest B the design may use, B caps, why none) at this filter."""
    b_max = rendered_max_stable_damping(ctx.device, rend)
    caps = _filter_caps(ctx, rend)
    if math.isnan(b_max):
        return b_max, math.nan, caps, "B_max of this filter and virtual mass is not resolved (a tangential crossing)"
    if not b_max > 0.0:
        return b_max, 0.0, caps, "no positive stiffness is stable for any virtual damping with this filter and mass"
    upper = min(b_max, min(caps.values(), default=math.inf))
    if not math.isfinite(upper):
        return b_max, upper, caps, ("the damper-only loop is stable for every B and no damping or noise limit was "
                                    "given: the design is unbounded in B")
    return b_max, upper, caps, None


def best_damping(ctx: FilterContext, rend: Rendering, points: int = 33, zoom_rounds: int = 6,
            polish: bool = True, brackets: int = 3) -> tuple[float, float, dict, float]:
    """(B*, objective at B*, B caps, B_max) at a fixed filter; objective −inf when no B is usable."""
    b_max, upper, caps, why = _b_range(ctx, rend)
    if why is not None:
        return 0.0, -math.inf, caps, b_max
    top = upper if upper < b_max else upper * (1 - 1e-9)
    bs = np.unique(np.concatenate([np.linspace(0.0, top, points), top * np.geomspace(1e-6, 1.0 / points, 6),
                                   top * (1 - np.geomspace(1e-6, 1e-2, 3))]))
    cache: dict[float, float] = {}

    def f(b: float) -> float:
        if not 0.0 <= b <= top:
            return -math.inf
        if b not in cache:
            cache[b] = fixed_filter_objective(ctx, rend, b)[0]
        return cache[b]
    vals = np.array([f(float(b)) for b in bs])
    best_b, best_v = float(bs[int(np.argmax(vals))]), float(vals.max())
    for i in np.argsort(-vals)[:brackets]:
        if not vals[i] > 0.0:
            break
        lo, hi = float(bs[max(i - 1, 0)]), float(bs[min(i + 1, bs.size - 1)])
        x, v = _zoom(f, lo, hi, float(bs[i]), float(vals[i]), rounds=zoom_rounds, polish=polish)
        if v > best_v:
            best_b, best_v = x, v
    return best_b, best_v, caps, b_max


def low_pass_rendering(order: int, cutoff: float, t: float, mass: float) -> Rendering:
    return rendering(LowPass(kind="low_pass", cutoff_hz=cutoff, order=1 if order == 1 else 2), mass, t)


def design_rendered_stiffness(device: Device, req: StiffnessRequirements, mass: float = 0.0,
                              velocity_filter=None):
    """The stiffest safe wall with this virtual mass M [kg] and velocity filter (``velocity_filter`` if given, else
    ``req.velocity_filter``): a StiffnessDesign whose ``velocity_filter`` says what was rendered."""
    from optim.stiffness.design import StiffnessDesign

    t0 = time.perf_counter()
    spec = velocity_filter if velocity_filter is not None else req.velocity_filter
    k_caps = req.stiffness_caps()
    k_caps.update(req.quantization_caps(device.encoder_resolution, device.coulomb_friction))
    ctx = FilterContext(device, req, float(mass), k_caps, req.gain_factor)
    d_pass, conservative = passivity_samples(device)
    pass_note = None
    if req.passivity:
        pass_note = (f"passivity tested with {d_pass} whole samples of delay (general Colgate–Schenkel with the "
                     "filter and virtual mass)" + (" (the fractional delay rounded up: conservative)"
                                                   if conservative else ""))
        if device.damping <= 0.0:
            return StiffnessDesign(status="infeasible", reason="passivity is impossible on this device: it has no "
                                   "physical damping (b = 0)", passivity_delay_samples=d_pass,
                                   passivity_note=pass_note, elapsed_ms=(time.perf_counter() - t0) * 1e3)
    if isinstance(spec, CutoffDesign):
        lo, hi = spec.band(device.sample_time)
        rend, b, solver, note = _design_cutoff(ctx, spec.order, lo, hi)
        filt = RenderedFilter("low_pass", rend.cutoff if rend is not None else None, spec.order, True, lo, hi, mass)
    else:
        r = rendering(spec, mass, device.sample_time)
        b, _, _, _ = best_damping(ctx, r)
        rend = _Fixed(r, None)
        solver, note = SolverInfo("exact B scan", details=(("method", _SCAN_METHOD),)), None
        cutoff = getattr(spec, "cutoff_hz", None)
        filt = RenderedFilter(getattr(spec, "kind", "backward_difference") if spec is not None else
                              "backward_difference", cutoff, getattr(spec, "order", None), False, mass=mass)
    return _finish(ctx, rend, b, filt, solver, note, pass_note, d_pass, t0)


_SCAN_METHOD = ("the exact objective min(g·K_cr(B), passive K(B), caps) of the rendered wall at 42 values of B "
                "(even, log-spaced near 0, next to the top of the B range), then nested grids and bounded Brent "
                "around the three best")


@dataclass(frozen=True)
class _Fixed:
    rendering: Rendering
    cutoff: float | None


def _finish(ctx: FilterContext, rend: _Fixed | None, b: float, filt: RenderedFilter, solver: SolverInfo, note: str | None,
            pass_note: str | None, d_pass: int, t0: float):
    from optim.stiffness.design import StiffnessDesign

    dev, req = ctx.device, ctx.req
    common = dict(passivity_delay_samples=d_pass if req.passivity else None, passivity_note=pass_note, solver=solver,
                  rendered=filt)

    def out(**kw):
        return StiffnessDesign(elapsed_ms=(time.perf_counter() - t0) * 1e3, **common, **kw)
    if rend is None:
        return out(status="failed" if note and note.startswith("failed") else "infeasible", reason=note)
    r = rend.rendering
    b_max, upper, caps, why = _b_range(ctx, r)
    if why is not None:
        return out(status="failed" if math.isnan(b_max) else "infeasible", reason=why,
                   max_stable_damping=b_max if math.isfinite(b_max) else None)
    b = min(b, upper)
    kcr_res = rendered_critical_stiffness(dev, b, r)
    kcr = kcr_res.critical_stiffness
    pk = largest_rendered_passive_stiffness(dev, b, r)[0] if req.passivity else None
    analysed = [ctx.gain * kcr] + ([pk] if pk is not None else [])
    k = min([*ctx.k_caps.values(), (1.0 - DESIGN_BACK_OFF) * min(analysed)])
    t = dev.sample_time
    sp, ng = step_peak(r.velocity, t), noise_gain(r.velocity, t)
    q = req.quantization
    cross = kcr_res.crossover_frequency
    filt = replace(filt, cutoff_hz=rend.cutoff if filt.designed else filt.cutoff_hz, step_peak=sp, noise_gain=ng,
                   force_step=b * q * sp if q is not None else None,
                   force_noise_rms=b * q * ng / math.sqrt(12.0) if q is not None else None,
                   crossover_cutoff_ratio=(cross / (2 * math.pi) / rend.cutoff if cross and rend.cutoff else None),
                   note=note)
    common["rendered"] = filt
    if not math.isfinite(k):
        return out(status="infeasible", reason="every positive stiffness is stable at this damping and filter and no "
                                               "stiffness limit was given: the design is unbounded",
                   max_stable_damping=b_max if math.isfinite(b_max) else None)
    if not k > 0.0:
        return out(status="infeasible", reason=kcr_res.reason or "no positive stiffness satisfies the requirements "
                                                                  "with this filter and virtual mass",
                   max_stable_damping=b_max if math.isfinite(b_max) else None)
    active = []
    if k >= ctx.gain * kcr * (1 - _ACTIVE_RTOL):
        active.append("min_gain_margin_db")
    if pk is not None and k >= pk * (1 - _ACTIVE_RTOL):
        active.append("passivity")
    active += [n for n, c in ctx.k_caps.items() if k >= c * (1 - _ACTIVE_RTOL)]
    active += [n for n, c in caps.items() if b >= c * (1 - _ACTIVE_RTOL)]
    lin = linear_estimate(dev, b)
    status, reason = "optimal", None
    if note is not None and note.startswith("not optimal"):
        status, reason = "failed", note
    return out(status=status, reason=reason, stiffness=k, damping=b, critical_stiffness=kcr,
               gain_margin_db=gain_margin_db(kcr, k), crossover_frequency=cross, linear_estimate=lin,
               linear_estimate_error=(lin - kcr) / kcr, max_stable_damping=b_max if math.isfinite(b_max) else None,
               active_constraints=tuple(active), back_off=DESIGN_BACK_OFF,
               sensitivity_note="no sensitivities for a rendered wall (velocity filter or virtual mass)")


# ================================================================ the designed cutoff

@dataclass
class _CutoffRef:
    rendering: Rendering
    cutoff: float


def _design_cutoff(ctx: FilterContext, order: int, lo: float, hi: float):
    """(the chosen filter, its B, solver record, note) for a low-pass of this order with cutoff in [lo, hi] Hz."""
    t = ctx.device.sample_time
    cutoffs = np.geomspace(lo, hi, FILTER_PROFILE_CUTOFFS)
    seeds = []
    for f in cutoffs:
        r = low_pass_rendering(order, float(f), t, ctx.mass)
        b, v, _, _ = best_damping(ctx, r, points=_B_PROFILE, zoom_rounds=1, polish=False, brackets=1)
        seeds.append((v, float(f), b))
    seeds.sort(key=lambda s: -s[0])
    v0, f0, b0 = seeds[0]
    if not v0 > 0.0:
        why = f"no positive stiffness meets the requirements at any of {cutoffs.size} cutoffs in [{lo:.6g}, {hi:.6g}] Hz"
        return None, 0.0, SolverInfo("exact cutoff profile"), why
    if not math.isfinite(v0):
        return _Fixed(low_pass_rendering(order, f0, t, ctx.mass), f0), b0, SolverInfo("exact cutoff profile"), None
    best = None
    for v_s, f_s, b_s in seeds[:2]:
        got = _nlp(ctx, order, lo, hi, f_s, b_s, v_s)
        if got is not None and (best is None or got[0] > best[0]):
            best = got
    # the profile's best point is a feasible exact design: an NLP answer below it is not the optimum; the exact
    # refinement over the cutoff (nested: the best B at each cutoff) decides then
    if best is None or best[0] < v0 * (1 - 1e-7):
        f_s, b_s, v_s = _refine_scan(ctx, order, lo, hi, seeds)
        why = (f"Ipopt's answer K = {best[0]:.6g} N/m is below the exact profile's best point {v0:.6g} N/m"
               if best is not None else "Ipopt did not converge from any seed")
        solver = SolverInfo("exact cutoff scan", details=(("why", why), ("method", (
            f"the best B (exact) at {FILTER_PROFILE_CUTOFFS} log-spaced cutoffs, then bounded Brent over ln f "
            "around the best")),))
        return _Fixed(low_pass_rendering(order, f_s, t, ctx.mass), f_s), b_s, solver, None
    v, f, b, sol, rounds = best
    solver = SolverInfo("ipopt", sol.return_status, sol.iterations, starts=2, details=(
        ("exchange_rounds", rounds), ("seed", {"cutoff_hz": f0, "damping": b0, "stiffness": v0})))
    return _Fixed(low_pass_rendering(order, f, t, ctx.mass), f), b, solver, None


def _refine_scan(ctx: FilterContext, order: int, lo: float, hi: float, seeds) -> tuple[float, float, float]:
    t = ctx.device.sample_time
    cut = sorted(s[1] for s in seeds)
    f0 = seeds[0][1]
    i = cut.index(f0)
    a, b = math.log(cut[max(i - 1, 0)]), math.log(cut[min(i + 1, len(cut) - 1)])
    memo: dict[float, tuple[float, float]] = {}

    def g(u: float) -> float:
        f = min(max(math.exp(u), lo), hi)
        if f not in memo:
            bb, v, _, _ = best_damping(ctx, low_pass_rendering(order, f, t, ctx.mass), points=_B_PROFILE, zoom_rounds=4)
            memo[f] = (v, bb)
        return memo[f][0]
    res = minimize_scalar(lambda u: -g(u), bounds=(a, b), method="bounded", options={"xatol": 1e-4})
    best = max(((v, f, bb) for f, (v, bb) in memo.items()), default=seeds[0])
    if seeds[0][0] > best[0]:
        best = seeds[0]
    del res
    return best[1], best[2], best[0]


def _nlp(ctx: FilterContext, order: int, lo: float, hi: float, f0: float, b0: float, v0: float):
    """(exact K [N/m], cutoff, B, solution, rounds) of the NLP from one seed, or None."""
    dev = ctx.device
    t, ks, bs = dev.sample_time, dev.stiffness_scale, dev.damping_scale
    req = ctx.req
    m = loop_matrices(dev)
    mu = ctx.mass / dev.mass
    d_pass = passivity_samples(dev)[0]
    r0 = low_pass_rendering(order, f0, t, ctx.mass)
    kres = rendered_critical_stiffness(dev, b0, r0)
    alpha_ref = max(v0 / ks, 1e-300)
    beta_ref = max(b0 / bs, 1e-6 * max(_b_range(ctx, r0)[0] / bs if math.isfinite(_b_range(ctx, r0)[0]) else 1.0,
                                       1e-300))
    nu_ref = f0 * t
    far = 50.0 * v0 / ctx.gain
    thetas = [c.frequency * t for c in kres.crossovers if c.stiffness <= far and c.frequency * t < math.pi - 1e-9]
    nyquist = any(c.frequency * t >= math.pi - 1e-9 for c in kres.crossovers)
    cuts: list[float] = []
    if req.passivity:
        cuts = [math.pi]
        th = largest_rendered_passive_stiffness(dev, b0, r0)[1]
        if th > 0.0:
            cuts.append(th)
    k_cap = min(ctx.k_caps.values(), default=math.inf)
    b_cap = min(req.damping_caps(t).get("max_damping", math.inf), math.inf)
    q = req.quantization
    sig_step = (req.max_force_noise * t * t / (dev.mass * q)) if q and req.max_force_noise else math.inf
    sig_rms = (req.max_force_noise_rms * t * t * math.sqrt(12.0) / (dev.mass * q)) if q and req.max_force_noise_rms \
        else math.inf
    x = [v0 / ks / alpha_ref, b0 / bs / beta_ref, 0.0]
    c_bounds = (math.log(lo * t / nu_ref), math.log(hi * t / nu_ref))
    b_hi = min(b_cap / bs, 1e30) / beta_ref
    sol, exact_k, f, b = None, -math.inf, f0, b0
    for rounds in range(1, _MAX_EXCHANGES + 1):
        key = CutoffKey(m.n, order, len(thetas), nyquist, N_CUTS if req.passivity else 0)
        params = cutoff_params(m.flat(), ctx.gain, alpha_ref, beta_ref, k_cap / ks, b_cap / bs, mu, dev.delta,
                               d_pass, nu_ref, sig_step, sig_rms, cuts, key.cuts)
        tb = [(max(th * 0.6, 1e-9), min(th * 1.4, math.pi)) for th in thetas]
        try:
            sol = solve_cutoff_problem(key, params, x + thetas, c_bounds, (0.0, b_hi), tb)
        except RuntimeError:
            return None
        if not (sol.success or sol.return_status in ("Solved_To_Acceptable_Level",
                                                     "Search_Direction_Becomes_Too_Small")):
            return None
        f = min(max(nu_ref * math.exp(sol.c) / t, lo), hi)
        b = max(sol.b * beta_ref * bs, 0.0)
        r = low_pass_rendering(order, f, t, ctx.mass)
        b_max, upper, _, why = _b_range(ctx, r)
        if why is not None:
            return None
        b = min(b, upper if upper < b_max else upper * (1 - 1e-9))
        kres = rendered_critical_stiffness(dev, b, r)
        k_nlp = sol.a * alpha_ref * ks
        changed = False
        if ctx.gain * kres.critical_stiffness < k_nlp * (1 - 1e-8):
            known = thetas + ([math.pi] if nyquist else [])
            for c in kres.crossovers:
                th = c.frequency * t
                if c.stiffness <= ctx.gain ** -1 * k_nlp * 1.01 and all(abs(th - k) > 1e-6 * th for k in known):
                    if th >= math.pi - 1e-9:
                        nyquist = True
                    else:
                        thetas.append(th)
                    changed = True
        pk = None
        if req.passivity:
            pk, th = largest_rendered_passive_stiffness(dev, b, r)
            if pk < k_nlp * (1 - 1e-7) and th > 0.0 and all(abs(th - c) > 1e-9 for c in cuts):
                cuts.append(th)
                changed = True
        exact_k = min([ctx.gain * kres.critical_stiffness, *ctx.k_caps.values()] + ([pk] if pk is not None else []))
        if not changed:
            break
        x = [sol.a, sol.b, sol.c]
        thetas = [sol.thetas[i] if i < len(sol.thetas) else th for i, th in enumerate(thetas)]
        thetas = [min(max(th, 1e-9), math.pi - 1e-9) for th in thetas]
    return exact_k, f, b, sol, rounds


def check_design_filter(req: StiffnessRequirements, sample_time: float) -> None:
    """Refuse a fixed filter's bad cutoff before any work (InputError naming requirements.velocity_filter.…)."""
    spec = req.velocity_filter
    try:
        if isinstance(spec, CutoffDesign):
            spec.band(sample_time)
        elif spec is not None:
            velocity_transfer(spec, sample_time)
    except InputError as exc:
        raise InputError(f"requirements.{exc.field}", exc.rule) from None
