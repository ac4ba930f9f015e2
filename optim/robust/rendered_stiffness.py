"""Robust stiffness design of a rendered wall: one (K, B) with a fixed velocity filter and virtual mass whose gain
margin holds for every device of an uncertainty box (ARCHITECTURE.md, "The rendered virtual environment").

The semi-infinite problem max_{K,B} K s.t. K ≤ g·K_cr(B; p) for every p of the box is solved by the scenario
exchange of optim.robust.stiffness, with the exact rendered analysis (optim.stability.rendered) in place of the
default wall's CasADi NLP:

1. scenarios: the nominal device (clipped into the box) and every corner of the paths that enter the loop;
2. the robust objective min(g·min_s K_cr(B; s), K caps) is maximised over B ∈ [0, min(min_s B_max(s), B caps)] by
   the exact B scan of the nominal rendered design (optim.stiffness.rendered_design: 42 values, nested grids and
   bounded Brent around the three best), each K_cr exact for that scenario's filter at its own sample time;
3. the whole box is searched for the device with the smallest rendered K_cr at that B (optim.robust.worst_case's
   Sobol + corners + pattern search, run to convergence), every evaluation the exact rendered analysis;
4. if its margin is short of the requirement by more than TOLERANCE_DB it becomes a scenario and step 2 runs again.

The stiffness returned is (1 − DESIGN_BACK_OFF) times the smallest g·K_cr of the scenarios and of the worst device
found, so every device the search evaluated meets the margin.  The filter is given in hertz: each device of the box
renders it at its own sample time.  Passivity, a designed cutoff and noise rules with an uncertain sample time are
refused (InputError naming the field): this path does not decide them.
"""

from __future__ import annotations

import math
import time

import numpy as np

from models.device import Device
from models.velocity_filter import Rendering, rendering
from models.velocity_noise import noise_gain, step_peak
from optim.errors import InputError
from optim.robust.box import STIFFNESS_PATHS, UncertaintyBox
from optim.robust.stiffness import TOLERANCE_DB, RobustStiffnessDesign
from optim.robust.stiffness_profile import initial_points
from optim.robust.worst_case import WorstCase, minimise_over_box
from optim.solver_info import SolverInfo
from optim.stability.margins import gain_margin_db
from optim.stability.rendered import rendered_critical_stiffness, rendered_max_stable_damping
from optim.stiffness.rendered_design import zoom_maximum
from optim.stiffness.rendered_filter import RenderedFilter
from optim.stiffness.requirements import DESIGN_BACK_OFF, CutoffDesign, StiffnessRequirements

__all__ = ["robust_rendered_stiffness", "rendered_worst_case", "box_rendered_critical_stiffness"]

_MAX_OUTER = 25
_ACTIVE_RTOL = 1e-6
_B_POINTS = 33


class _Scenario:
    """One device of the box with its rendering and its rendered B_max."""

    def __init__(self, box: UncertaintyBox, point: np.ndarray, spec, mass: float) -> None:
        self.point = point
        self.device = box.device_at(point)
        self.rendering = rendering(spec, mass, self.device.sample_time)
        self.b_max = rendered_max_stable_damping(self.device, self.rendering)

    def kcr(self, b: float) -> float:
        return rendered_critical_stiffness(self.device, b, self.rendering).critical_stiffness


def _renderings(devices: list[Device], spec, mass: float, memo: dict[float, Rendering]) -> list[Rendering]:
    out = []
    for d in devices:
        if d.sample_time not in memo:
            memo[d.sample_time] = rendering(spec, mass, d.sample_time)
        out.append(memo[d.sample_time])
    return out


def box_rendered_critical_stiffness(box: UncertaintyBox, unit: np.ndarray, damping: float, spec, mass: float,
                                    memo: dict[float, Rendering] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The rendered K_cr(B) [N/m] and crossover angle [rad/sample] at unit-cube points (rows) of the box, each by the
    exact rendered analysis with the filter at that device's sample time (ArithmeticError where one is unresolved)."""
    memo = {} if memo is None else memo
    devs = box.devices(box.to_box(np.atleast_2d(unit)))
    ks, ths = np.empty(len(devs)), np.empty(len(devs))
    for i, (d, r) in enumerate(zip(devs, _renderings(devs, spec, mass, memo))):
        res = rendered_critical_stiffness(d, damping, r)
        k = res.critical_stiffness
        if k is None or math.isnan(k):
            raise ArithmeticError(f"the rendered K_cr is not resolved at a device of the box ({res.reason})")
        ks[i] = k
        ths[i] = res.crossover_frequency * d.sample_time if res.crossover_frequency is not None else math.nan
    return ks, ths


def rendered_worst_case(box: UncertaintyBox, stiffness: float, damping: float, spec, mass: float, *,
                        samples: int = 128, starts: int = 3, seed: int = 0) -> WorstCase:
    """The device of the box with the smallest rendered K_cr(B) (the global search of optim.robust.worst_case with
    the exact rendered analysis at each point)."""
    active = box.relevant(STIFFNESS_PATHS)
    memo: dict[float, Rendering] = {}
    best_u, best_k, best_a, evals = minimise_over_box(
        box, active, lambda u: box_rendered_critical_stiffness(box, u, damping, spec, mass, memo), samples=samples,
        starts=starts, seed=seed)
    point = box.to_box(best_u)
    dev = box.device_at(point)
    freq = best_a / dev.sample_time if math.isfinite(best_a) else None
    margin = 20.0 * math.log10(best_k / stiffness) if best_k > 0 else -math.inf
    return WorstCase(point, dev, best_k, freq, margin, evals)


def _check(req: StiffnessRequirements, box: UncertaintyBox, spec, mass: float) -> None:
    if isinstance(spec, CutoffDesign):
        raise InputError("requirements.velocity_filter.design", "a designed cutoff with requirements.uncertainty is "
                         "not available (the robust box takes a fixed filter): give a cutoff_hz, or design the "
                         "cutoff for one device")
    if req.passivity:
        raise InputError("requirements.passivity", "a robust design of a rendered wall (velocity filter or virtual "
                         "mass) does not decide passivity over the box yet: drop passivity, or give one device")
    if req.passive_with_quantization:
        raise InputError("requirements.passive_with_quantization", "not available in the robust design")
    if "device.sample_time" in box.paths and box.relevant(frozenset({"device.sample_time"})).any():
        for name in ("max_force_noise", "max_force_noise_rms"):
            if getattr(req, name) is not None and req.quantization is not None:
                raise InputError(f"requirements.{name}", "the noise rules of a rendered wall with an uncertain "
                                 "device.sample_time are not available (the filter's noise gain moves with T): "
                                 "fix the sample time or drop the rule")
    for t in sorted({float(d.sample_time) for d in box.devices(box.corners())}):
        try:
            rendering(spec, mass, t)
        except InputError as exc:
            raise InputError("requirements.uncertainty.device.sample_time", f"at T = {t:g} s the velocity filter "
                             f"is not valid ({exc.field}: {exc.rule})") from None


def robust_rendered_stiffness(nominal: Device, req: StiffnessRequirements, box: UncertaintyBox, mass: float,
                              spec) -> RobustStiffnessDesign:
    """The largest K (and its B) whose gain margin holds for every device of the box, with the velocity filter
    ``spec`` (fixed, cutoff in Hz) and virtual mass ``mass`` [kg] rendered (module doc)."""
    t0 = time.perf_counter()
    _check(req, box, spec, mass)
    ignored = tuple(p for p, on in zip(box.paths, box.relevant(frozenset(box.paths) - STIFFNESS_PATHS)) if on)
    t_nom = nominal.sample_time
    r_nom = rendering(spec, mass, t_nom)
    sp, ng = step_peak(r_nom.velocity, t_nom), noise_gain(r_nom.velocity, t_nom)
    filt = RenderedFilter(getattr(spec, "kind", "backward_difference") if spec is not None else "backward_difference",
                          getattr(spec, "cutoff_hz", None), getattr(spec, "order", None), False, mass=float(mass),
                          step_peak=sp, noise_gain=ng)
    k_caps = req.stiffness_caps()
    b_caps = req.damping_caps(t_nom, sp, ng)
    k_cap, b_cap = min(k_caps.values(), default=math.inf), min(b_caps.values(), default=math.inf)
    g = req.gain_factor

    def done(**kw) -> RobustStiffnessDesign:
        return RobustStiffnessDesign(elapsed_ms=(time.perf_counter() - t0) * 1e3, ignored_paths=ignored,
                                     rendered=filt, **kw)
    scenarios = [_Scenario(box, p, spec, mass) for p in initial_points(box)]
    evals, it, b, k_best = 0, 0, 0.0, 0.0
    wc: WorstCase | None = None
    for it in range(1, _MAX_OUTER + 1):
        b_maxes = [sc.b_max for sc in scenarios]
        if any(math.isnan(x) for x in b_maxes):
            return done(status="failed", iterations=it, reason="B_max of a device of the box with this filter and "
                        "virtual mass is not resolved (a tangential crossing)")
        upper = min(min(b_maxes), b_cap)
        if not upper > 0:
            return done(status="infeasible", iterations=it, reason="a device of the box has no stable positive "
                        "stiffness for any virtual damping with this filter and virtual mass")
        if not math.isfinite(upper):
            return done(status="infeasible", iterations=it, reason="the damper-only loop is stable for every B on "
                        "every scenario and no max_damping was given: the design is unbounded in B")
        b, k_best = _best_damping(scenarios, g, k_cap, upper, upper < min(b_maxes))
        if not k_best > 0:
            return done(status="infeasible", iterations=it, scenarios=tuple(box.describe(s.point) for s in scenarios),
                        reason="no positive stiffness meets the gain margin on every device of the box for any B "
                               f"in [0, {upper:.6g}] N·s/m with this filter and virtual mass")
        if not math.isfinite(k_best):
            return done(status="infeasible", iterations=it, reason="no crossover and no max_stiffness: the design "
                                                                   "is unbounded")
        wc = rendered_worst_case(box, k_best, b, spec, mass, seed=it)
        evals += wc.evaluations
        if wc.margin_db >= req.min_gain_margin_db - TOLERANCE_DB:
            break
        if any(np.array_equal(wc.point, sc.point) for sc in scenarios):
            return done(status="failed", iterations=it, evaluations=evals, reason="the worst device is already a "
                        "scenario but the B scan's design misses its margin")
        scenarios.append(_Scenario(box, wc.point, spec, mass))
    else:
        return done(status="failed", iterations=it, evaluations=evals,
                    reason=f"the scenario exchange did not settle in {_MAX_OUTER} rounds",
                    scenarios=tuple(box.describe(sc.point) for sc in scenarios))
    assert wc is not None
    per = [sc.kcr(b) for sc in scenarios]
    analysed = [g * wc.critical_stiffness, *(g * v for v in per)]
    k = min([*k_caps.values(), (1.0 - DESIGN_BACK_OFF) * min(analysed)])
    if not k > 0:
        return done(status="infeasible", iterations=it, evaluations=evals,
                    reason="no positive stiffness meets the gain margin on every device of the box")
    nom_dev = box.device_at(box.nominal_point())
    nom = rendered_critical_stiffness(nom_dev, b, rendering(spec, mass, nom_dev.sample_time)).critical_stiffness
    active = []
    if k >= g * wc.critical_stiffness * (1 - _ACTIVE_RTOL):
        active.append("min_gain_margin_db")
    active += [n for n, cap in k_caps.items() if k >= cap * (1 - _ACTIVE_RTOL)]
    active += [n for n, cap in b_caps.items() if b >= cap * (1 - _ACTIVE_RTOL)]
    margin = gain_margin_db(wc.critical_stiffness, k)
    worst = {"device": box.describe(wc.point), "critical_stiffness": wc.critical_stiffness,
             "crossover_frequency": wc.crossover_frequency, "gain_margin_db": margin}
    q = req.quantization
    filt_out = RenderedFilter(filt.kind, filt.cutoff_hz, filt.order, False, mass=float(mass), step_peak=sp,
                              noise_gain=ng, force_step=b * q * sp if q is not None else None,
                              force_noise_rms=b * q * ng / math.sqrt(12.0) if q is not None else None,
                              crossover_cutoff_ratio=(wc.crossover_frequency / (2 * math.pi) / filt.cutoff_hz
                                                      if wc.crossover_frequency and filt.cutoff_hz else None),
                              note="the filter (cutoff in Hz) is rendered at each device's own sample time; "
                                   "step_peak and noise_gain at the nominal one")
    solver = SolverInfo("exact B scan", details=(("method", _METHOD), ("structure", {"scenarios": len(scenarios)})))
    return RobustStiffnessDesign(
        status="optimal", stiffness=k, damping=b, gain_margin_db=margin, worst_case=worst,
        nominal_critical_stiffness=nom, nominal_gain_margin_db=gain_margin_db(nom, k),
        scenarios=tuple(box.describe(sc.point) for sc in scenarios), iterations=it, evaluations=evals,
        active_constraints=tuple(active), back_off=DESIGN_BACK_OFF, ignored_paths=ignored, solver=solver,
        rendered=filt_out, elapsed_ms=(time.perf_counter() - t0) * 1e3)


_METHOD = ("scenario exchange: the exact robust objective min(g·min_s K_cr(B; s), caps) of the rendered wall over "
           "the scenarios at 42 values of B, nested grids and bounded Brent around the three best; the box's worst "
           "device at that B by the exact rendered analysis (Sobol + corners + pattern search) joins the scenarios "
           "until it meets the margin")


def _best_damping(scenarios: list[_Scenario], g: float, k_cap: float, upper: float,
                  capped: bool) -> tuple[float, float]:
    """(B*, min(g·min_s K_cr(B*; s), K cap)) maximised over B ∈ [0, upper] (B_max itself excluded)."""
    top = upper if capped else upper * (1 - 1e-9)
    cache: dict[float, float] = {}

    def f(x: float) -> float:
        if not 0.0 <= x <= top:
            return -math.inf
        if x not in cache:
            cache[x] = min(k_cap, g * min(sc.kcr(x) for sc in scenarios))
        return cache[x]
    bs = np.unique(np.concatenate([np.linspace(0.0, top, _B_POINTS), top * np.geomspace(1e-6, 1.0 / _B_POINTS, 6),
                                   top * (1 - np.geomspace(1e-6, 1e-2, 3))]))
    vals = np.array([f(float(x)) for x in bs])
    best_b, best_v = float(bs[int(np.argmax(vals))]), float(vals.max())
    for i in np.argsort(-vals)[:3]:
        if not vals[i] > 0.0 or not math.isfinite(vals[i]):
            break
        lo, hi = float(bs[max(i - 1, 0)]), float(bs[min(i + 1, bs.size - 1)])
        x, v = zoom_maximum(f, lo, hi, float(bs[i]), float(vals[i]))
        if v > best_v:
            best_b, best_v = x, v
    return best_b, best_v
