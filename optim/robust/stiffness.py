"""Robust stiffness design: one wall (K, B) whose gain margin holds for every device of a box.

Scenario exchange (a cutting-plane method for the semi-infinite problem
max_{K,B} K  s.t.  K ≤ g·K_cr(B; p) for every p in the box):

1. scenarios: the nominal device (clipped into the box) and every corner;
2. the CasADi NLP (problem.py) maximises K with one margin constraint per tracked
   crossover of every scenario, seeded from each scenario's boundary curve
   (optim.stiffness.profile) on the B interval where no scenario's crossovers
   are born or die; each scenario is re-checked by the exact analysis at the
   chosen B and a crossover the NLP did not know is added (inner exchange);
3. the whole box is searched for the worst device at that (K, B)
   (worst_case.py: Sobol + corners + batched pattern search, exact analysis);
4. if its margin is short of the requirement by more than 1e-6 dB it becomes a
   scenario and the NLP is solved again.
The stiffness returned is finally clipped to g·K_cr of the worst device found,
so every device the search evaluated meets the margin exactly.

With ``passivity`` the box's passivity is decided by finitely many corners (b_min, T, n)
found exactly (optim/robust/passivity.py: P is linear in T for each whole delay n, and n
jumps with ⌈t_d/T⌉); the NLP carries passivity cuts (corner, angle), an exchange adds
the most violated angle of every corner the solution is not passive on (cutting planes,
as optim.stiffness.design), and K is finally clipped to the largest stiffness passive on
every corner at the chosen B.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from models.device import Device
from optim.stability.margins import critical_stiffness, gain_margin_db, max_stable_damping
from optim.stability.passivity import kernel, largest_passive_stiffness, passive_alpha_on_grid, passivity_margin
from optim.stiffness.loop import loop_matrices
from optim.stiffness.profile import BoundaryCurve, boundary_curve, coarse_critical, crossings_at
from optim.stiffness.requirements import DESIGN_BACK_OFF, StiffnessRequirements

from optim.robust.box import STIFFNESS_PATHS, UncertaintyBox
from optim.robust.passivity import (PassivityCorner, describe_delays, largest_robust_passive_stiffness, passivity_corners,
                        worst_passivity)
from optim.robust.problem import RobustKey, cut_slots, solve_robust
from optim.robust.worst_case import WorstCase, worst_case_stiffness

__all__ = ["RobustStiffnessDesign", "robust_design_stiffness", "TOLERANCE_DB"]

TOLERANCE_DB = 1e-6          # the worst case must meet the margin to this (issue 12)
_MAX_OUTER = 25
_MAX_INNER = 12
_MAX_INNER_PASSIVITY = 40     # cutting planes converge linearly at a smooth passivity optimum
_PASSIVITY_RTOL = 1e-7        # as optim.stiffness.design: stop the cuts here, then clip K to the exact bound
_VERIFY_RTOL = 1e-8


@dataclass(frozen=True)
class RobustStiffnessDesign:
    status: str
    """optimal | infeasible | failed."""
    stiffness: float | None = None
    """K [N/m]."""
    damping: float | None = None
    """B [N·s/m]."""
    gain_margin_db: float | None = None
    """worst-case margin over the box, 20·log10(K_cr(B; worst)/K) [dB]."""
    worst_case: dict | None = None
    """the worst device found: its box values, K_cr [N/m], crossover ω [rad/s], margin [dB]."""
    nominal_critical_stiffness: float | None = None
    """K_cr(B) of the nominal device [N/m]."""
    nominal_gain_margin_db: float | None = None
    scenarios: tuple[dict, ...] = ()
    """the box points the NLP used (path → value)."""
    iterations: int = 0
    """scenario-exchange rounds (NLP + worst-case search)."""
    evaluations: int = 0
    """exact analyses spent by the worst-case searches."""
    active_constraints: tuple[str, ...] = ()
    back_off: float | None = None
    """K sits this far (relative) below its binding limit (optim.stiffness.requirements.DESIGN_BACK_OFF)."""
    ignored_paths: tuple[str, ...] = ()
    """uncertain paths that do not enter the stiffness loop (nor passivity, when it is required)."""
    passivity_worst_case: dict | None = None
    """with passivity: the box's least passive device at (K, B): its box values, whole delay samples used,
    whether it is only approached (T → its value from below), b, sup_θ P [N·s/m], margin b − sup P [N·s/m]."""
    passivity_delay_samples: int | None = None
    """with passivity: whole samples of delay of that device."""
    passivity_note: str | None = None
    reason: str | None = None
    solver: dict = field(default_factory=dict)
    elapsed_ms: float = 0.0


@dataclass
class _Scenario:
    point: np.ndarray
    device: Device
    b_max: float
    curve: BoundaryCurve | None = None
    crossings: list = field(default_factory=list)     # [(θ, (lo, hi))]
    nyquist: bool = False
    beta_hi: float | None = None                      # the β range the curve was sampled for


def _done(t0: float, **kw) -> RobustStiffnessDesign:
    return RobustStiffnessDesign(elapsed_ms=(time.perf_counter() - t0) * 1e3, **kw)


def _scenario(box: UncertaintyBox, point: np.ndarray) -> _Scenario:
    dev = box.device_at(point)
    return _Scenario(point, dev, max_stable_damping(dev))


def _initial_points(box: UncertaintyBox) -> np.ndarray:
    base = box.nominal_point()
    active = box.relevant(STIFFNESS_PATHS)
    pts = [base]
    for c in box.corners():
        p = base.copy()
        p[active] = c[active]
        pts.append(p)
    return np.unique(np.array(pts), axis=0)


def _piece_bounds(curve: BoundaryCurve, theta: float) -> tuple[float, float]:
    for p in curve.pieces:
        lo, hi = min(p.theta_lo, p.theta_hi), max(p.theta_lo, p.theta_hi)
        if lo <= theta <= hi:
            return lo, hi
    return max(theta * 0.5, 1e-9), min(math.pi, theta * 1.5)


def _interval(sc: _Scenario, beta: float, beta_hi: float) -> tuple[float, float]:
    """The scenario's fold-free β interval around β (as optim.stiffness.design._interval)."""
    pts = [0.0, *sc.curve.breakpoints, beta_hi]
    lo = max(p for p in pts if p <= beta)
    hi = min((p for p in pts if p > beta), default=beta_hi)
    w = hi - lo
    return (lo + 1e-9 * w if lo > 0 else 0.0), hi - 1e-9 * w


@dataclass
class _Passivity:
    """The box's passivity corners and the cuts (corner index, θ) the exchange has found; a cut is a valid
    constraint for every B and K, so the cuts are kept across the scenario rounds."""

    corners: list[PassivityCorner]
    cuts: list[tuple[int, float]] = field(default_factory=list)

    def add(self, i: int, theta: float) -> bool:
        if any(j == i and abs(theta - t) <= 1e-12 for j, t in self.cuts):
            return False
        self.cuts.append((i, float(theta)))
        return True

    def rows(self, k_ref: float, b_ref: float) -> np.ndarray:
        """The cuts as (u, v, w) rows of problem.py: K·T·s/2 − B·c ≤ b over b, in k = K/K_ref, b = B/B_ref."""
        rows = []
        for i, theta in self.cuts:
            c = self.corners[i]
            s, cos = kernel(np.array([theta]), c.delay_samples)
            rows.append((k_ref * c.sample_time * s[0] / (2 * c.damping), b_ref * cos[0] / c.damping, 1.0))
        return np.array(rows, float).reshape(-1, 3)

    def coarse(self, bgrid: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """On the B grid, per corner (rows): passive K [N/m] and the angle that binds (a seed on optim.stability.passivity's
        θ grid); and per B the corner with the smallest."""
        ks, thetas = [], []
        for c in self.corners:
            # Table 1 with m = 1 (passivity does not depend on the mass): δ = bT, β = BT, K = α/T²
            alpha, theta = passive_alpha_on_grid(c.damping * c.sample_time, c.delay_samples, bgrid * c.sample_time)
            ks.append(alpha / c.sample_time ** 2)
            thetas.append(theta)
        return np.array(ks), np.array(thetas), np.argmin(np.array(ks), axis=0)

    def exchange(self, k: float, b: float) -> bool:
        """Add the most violated angle of every corner on which (K, B) is not passive; True if any was added."""
        changed = False
        for i, c in enumerate(self.corners):
            if k > largest_passive_stiffness(c.device, b).stiffness * (1 + _PASSIVITY_RTOL):
                check = passivity_margin(c.device, k, b)
                if check.worst_angle is not None:
                    changed |= self.add(i, check.worst_angle)
        return changed


def robust_design_stiffness(nominal: Device, requirements: StiffnessRequirements,
                            box: UncertaintyBox) -> RobustStiffnessDesign:
    """The largest K (and its B) whose gain margin (and passivity, if required) holds for every device of the box."""
    t0 = time.perf_counter()
    req = requirements
    ignored = tuple(p for p, on in zip(box.paths, box.relevant(frozenset(box.paths) - STIFFNESS_PATHS)) if on)
    passivity, pkw = None, {}
    if req.passivity:
        corners = passivity_corners(box)
        pkw = {"passivity_note": (f"passivity tested on every whole-sample delay ⌈t_d/T⌉ of the box "
                                  f"({describe_delays(corners)}) at its smallest physical damping "
                                  f"b = {corners[0].damping:.6g} N·s/m; a fractional delay is rounded up to the next "
                                  "whole sample (conservative)")}
        if corners[0].damping <= 0.0:
            return _done(t0, status="infeasible", ignored_paths=ignored, **pkw,
                         reason="passivity required but a device of the box has no physical damping: no stiffness is "
                                "passive (b must exceed P(θ) ≥ 0 at some θ)")
        passivity = _Passivity(corners)
    t_min = min(d.sample_time for d in box.devices(box.corners()))
    k_caps, b_caps = req.stiffness_caps(), req.damping_caps(t_min)   # B·q/T ≤ F_noise binds at the smallest T
    k_cap, b_cap = min(k_caps.values(), default=math.inf), min(b_caps.values(), default=math.inf)
    g = req.gain_factor
    scenarios = [_scenario(box, p) for p in _initial_points(box)]
    if any(sc.device.damping <= 0.0 for sc in scenarios):
        return _done(t0, status="failed", ignored_paths=ignored, **pkw,
                     reason="a device of the box has no physical damping: robust designs do not handle b = 0 yet "
                            "(the nominal design does: POST /v1/design/stiffness without uncertainty)")
    evals, last_wc, it, sol, k_nlp, b = 0, None, 0, None, 0.0, 0.0
    for it in range(1, _MAX_OUTER + 1):
        upper_b = min(min(sc.b_max for sc in scenarios), b_cap)
        if not upper_b > 0:
            return _done(t0, status="infeasible", iterations=it, ignored_paths=ignored, **pkw,
                         reason="a device of the box has no stable positive stiffness for any virtual damping")
        if not math.isfinite(upper_b):
            return _done(t0, status="infeasible", iterations=it, ignored_paths=ignored, **pkw,
                         reason="the damper-only loop is stable for every B on every scenario and no max_damping "
                                "was given: the design is unbounded in B")
        out = _solve_scenarios(scenarios, g, upper_b, k_cap, b_cap, passivity)
        if isinstance(out, str):
            status = "infeasible" if out.startswith("no positive") else "failed"
            return _done(t0, status=status, reason=out, iterations=it, ignored_paths=ignored, **pkw,
                         scenarios=tuple(box.describe(sc.point) for sc in scenarios))
        sol, k_nlp, b = out
        last_wc = worst_case_stiffness(box, k_nlp, b, seed=it)
        evals += last_wc.evaluations
        if last_wc.margin_db >= req.min_gain_margin_db - TOLERANCE_DB:
            break
        if any(np.array_equal(last_wc.point, sc.point) for sc in scenarios):
            return _done(t0, status="failed", iterations=it, evaluations=evals, ignored_paths=ignored, **pkw,
                         reason="the worst device is already a scenario but the NLP's design misses its margin")
        scenarios.append(_scenario(box, last_wc.point))
    else:
        return _done(t0, status="failed", iterations=it, evaluations=evals, ignored_paths=ignored, **pkw,
                     reason=f"the scenario exchange did not settle in {_MAX_OUTER} rounds",
                     scenarios=tuple(box.describe(sc.point) for sc in scenarios))
    return _finish(t0, nominal, box, req, scenarios, sol, k_nlp, b, last_wc, it, evals, ignored, k_caps, b_caps,
                   passivity, pkw)


def _solve_scenarios(scenarios: list[_Scenario], g: float, upper_b: float, k_cap: float, b_cap: float,
                     passivity: _Passivity | None):
    """The NLP over the current scenarios with its inner exchange of crossovers (and passivity cuts):
    (solution, K, B) or a reason."""
    for sc in scenarios:
        beta_hi = upper_b / sc.device.damping_scale
        if sc.curve is None or sc.beta_hi != beta_hi:
            sc.curve = boundary_curve(sc.device, beta_hi)
            sc.beta_hi = beta_hi
    # coarse robust profile: min over scenarios of g·K_cr(B) (and over passivity corners of the passive K),
    # on one physical B grid
    bgrid = np.unique(np.concatenate([np.linspace(0.0, upper_b, 241)[:-1],
                                      upper_b * (1 - np.geomspace(1e-6, 1e-2, 5)),
                                      # a passive wall needs B of the order of b, often ≪ B_max: a log part too
                                      upper_b * np.geomspace(1e-7, 1e-2, 81 if passivity is not None else 0),
                                      *[np.array(sc.curve.breakpoints) * sc.device.damping_scale for sc in scenarios]]))
    bgrid = bgrid[(bgrid >= 0) & (bgrid < upper_b)]
    obj = np.full(bgrid.shape, np.inf)
    for sc in scenarios:
        obj = np.minimum(obj, g * coarse_critical(sc.curve, bgrid / sc.device.damping_scale)
                         * sc.device.stiffness_scale)
    obj = np.minimum(obj, k_cap)
    if passivity is not None:
        pk, pth, who = passivity.coarse(bgrid)
        obj = np.minimum(obj, pk.min(axis=0))
    i = int(np.argmax(obj))
    if not obj[i] > 0:
        what = "is passive and meets the gain margin" if passivity is not None else "meets the gain margin"
        return f"no positive stiffness {what} on every device of the box for any B in [0, {upper_b:.6g}] N·s/m"
    if not obj[i] < 1e300:
        return "no positive stiffness meets the gain margin: the design is unbounded (no crossover and no max_stiffness)"
    b0, k0 = float(bgrid[i]), float(obj[i])
    if passivity is not None:
        # seeds, as optim.stiffness.design: for every corner whose passive K at b0 is within 20 % of the smallest,
        # its binding angle there, π and the kernel's zeros (where P = −B·cos((n+1)θ) bounds B alone)
        for j in np.nonzero(pk[:, i] <= 1.2 * pk[who[i], i])[0]:
            n = passivity.corners[j].delay_samples
            for theta in (float(pth[j, i]), math.pi, *(2 * math.pi * q / (2 * n + 1) for q in range(1, min(n, 4) + 1))):
                passivity.add(int(j), theta)
    lo, hi = 0.0, upper_b
    for sc in scenarios:
        bs = sc.device.damping_scale
        a, c = _interval(sc, b0 / bs, upper_b / bs)
        lo, hi = max(lo, a * bs), min(hi, c * bs)
        far = 50.0 * k0 / g / sc.device.stiffness_scale
        sc.crossings = [(t, _piece_bounds(sc.curve, t)) for t, al in crossings_at(sc.curve, b0 / bs, with_alpha=True)
                        if al <= far]
        sc.nyquist = bool(sc.curve.nyquist_alpha(np.array([b0 / bs]))[0] > 0)
    k_ref, b_ref = k0, max(b0, 1e-2 * upper_b)
    gparams = np.array([g, k_ref, b_ref, k_cap if math.isfinite(k_cap) else 1e300,
                        b_cap if math.isfinite(b_cap) else 1e300])
    flats = [np.concatenate([loop_matrices(sc.device).flat(), [sc.device.stiffness_scale, sc.device.damping_scale]])
             for sc in scenarios]
    n_states = loop_matrices(scenarios[0].device).n
    x_kb = [1.0, b0 / b_ref]
    for _ in range(_MAX_INNER if passivity is None else _MAX_INNER_PASSIVITY):
        cuts = passivity.rows(k_ref, b_ref) if passivity is not None else None
        key = RobustKey(n_states, tuple((len(sc.crossings), sc.nyquist) for sc in scenarios),
                        cut_slots(0 if cuts is None else cuts.shape[0]))
        x0 = np.array(x_kb + [t for sc in scenarios for t, _ in sc.crossings])
        bounds = [bb for sc in scenarios for _, bb in sc.crossings]
        sol = solve_robust(key, gparams, flats, x0, (lo / b_ref, hi / b_ref), bounds, cuts)
        if not sol.success:
            return f"Ipopt did not converge: {sol.return_status}"
        k, b = sol.k * k_ref, max(sol.b * b_ref, 0.0)
        changed = False
        for sc, thetas in zip(scenarios, sol.thetas):
            sc.crossings = [(t, bb) for t, (_, bb) in zip(thetas, sc.crossings)]
            exact = critical_stiffness(sc.device, b, b_max=sc.b_max)
            if k > g * exact.critical_stiffness * (1 + _VERIFY_RTOL) and exact.crossover_frequency is not None:
                th = exact.crossover_frequency * sc.device.sample_time
                if th >= math.pi * (1 - 1e-9):
                    if not sc.nyquist:
                        sc.nyquist, changed = True, True
                elif all(abs(th - t) > 1e-7 * th for t, _ in sc.crossings):
                    sc.crossings.append((th, _piece_bounds(sc.curve, th)))
                    changed = True
        if passivity is not None:
            changed |= passivity.exchange(k, b)
        if not changed:
            return sol, k, b
        x_kb = [sol.k, sol.b]
    return "the exchange of crossovers" + (" and passivity angles" if passivity is not None else "") + " did not settle"


def _finish(t0, nominal, box, req, scenarios, sol, k_nlp, b, wc: WorstCase, it, evals, ignored, k_caps, b_caps,
            passivity: _Passivity | None, pkw: dict):
    g = req.gain_factor
    per_scenario = [critical_stiffness(sc.device, b, b_max=sc.b_max).critical_stiffness for sc in scenarios]
    analysed = [g * wc.critical_stiffness, *(g * v for v in per_scenario)]
    k_pass = None
    if passivity is not None:
        k_pass, _ = largest_robust_passive_stiffness(passivity.corners, b)
        analysed.append(k_pass)
    # strictly inside the analysed limits, caps met as K ≤ cap (optim.stiffness.requirements.DESIGN_BACK_OFF)
    k = min([k_nlp, *k_caps.values(), (1.0 - DESIGN_BACK_OFF) * min(analysed)])
    if not k > 0:
        what = "is passive and meets the gain margin" if passivity is not None else "meets the gain margin"
        return _done(t0, status="infeasible", iterations=it, evaluations=evals, ignored_paths=ignored, **pkw,
                     reason=f"no positive stiffness {what} on every device of the box")
    nom_dev = box.device_at(box.nominal_point())
    nom = critical_stiffness(nom_dev, b).critical_stiffness
    active = []
    if k >= g * wc.critical_stiffness * (1 - 1e-6):
        active.append("min_gain_margin_db")
    if k_pass is not None and k >= k_pass * (1 - 1e-6):
        active.append("passivity")
    active += [n for n, cap in k_caps.items() if k >= cap * (1 - 1e-6)]
    active += [n for n, cap in b_caps.items() if b >= cap * (1 - 1e-6)]
    worst = {"device": box.describe(wc.point), "critical_stiffness": wc.critical_stiffness,
             "crossover_frequency": wc.crossover_frequency, "gain_margin_db": gain_margin_db(wc.critical_stiffness, k)}
    solver = {"name": "ipopt", "return_status": sol.return_status, "iterations": sol.iterations,
              "structure": {"scenarios": len(scenarios),
                            "crossovers": [len(t) for t in sol.thetas]}}
    if passivity is not None:
        pw = worst_passivity(passivity.corners, k, b)
        c = pw.corner
        pkw = {**pkw, "passivity_delay_samples": c.delay_samples, "passivity_worst_case": {
            "device": box.describe(c.point), "delay_samples_used": c.delay_samples, "approached": c.approached,
            "damping": c.damping, "required_damping": pw.check.required_damping, "passivity_margin": pw.margin,
            "worst_angle": pw.check.worst_angle}}
        solver["structure"].update(passivity_corners=len(passivity.corners), passivity_cuts=len(passivity.cuts))
    return _done(t0, status="optimal", stiffness=k, damping=b, gain_margin_db=worst["gain_margin_db"],
                 worst_case=worst, nominal_critical_stiffness=nom, nominal_gain_margin_db=gain_margin_db(nom, k),
                 scenarios=tuple(box.describe(sc.point) for sc in scenarios), iterations=it, evaluations=evals,
                 active_constraints=tuple(active), back_off=DESIGN_BACK_OFF, ignored_paths=ignored, solver=solver,
                 **pkw)
