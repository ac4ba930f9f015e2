"""Robust stiffness design: one wall (K, B) whose gain margin holds for every device of a box.

Scenario exchange (a cutting-plane method for the semi-infinite problem
max_{K,B} K  s.t.  K ≤ g·K_cr(B; p) for every p in the box):

1. scenarios: the nominal device (clipped into the box) and every corner;
2. the CasADi NLP (problem.py) maximises K with one margin constraint per tracked
   crossover of every scenario, seeded from each scenario's boundary curve
   (optim.stiffness.profile) on the B interval where no scenario's crossovers
   are born or die; each scenario is re-checked by the exact analysis at the
   chosen B and a crossover the NLP did not know is added (inner exchange).
   The steps live in stiffness_profile.py (the coarse robust profile over B),
   stiffness_seeding.py (the NLP's start) and stiffness_exchange.py (the NLP
   and its exact re-check); a round's outcome is typed (solved / infeasible /
   failed), never told apart by its message;
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
from dataclasses import dataclass
from typing import Literal

import numpy as np

from models.device import Device
from optim.errors import InputError
from optim.robust.box import STIFFNESS_PATHS, UncertaintyBox
from optim.robust.passivity import describe_delays, largest_robust_passive_stiffness, passivity_corners, worst_passivity
from optim.robust.passivity_cuts import PassivityCuts
from optim.robust.stiffness_exchange import ExchangeOutcome, exchange
from optim.robust.stiffness_profile import Scenario, coarse_profile, initial_points, scenario_at
from optim.robust.stiffness_seeding import seed
from optim.robust.worst_case import WorstCase, worst_case_stiffness
from optim.solver_info import NO_SOLVER, SolverInfo
from optim.stability.margins import critical_stiffness, gain_margin_db
from optim.stiffness.rendered_filter import RenderedFilter
from optim.stiffness.requirements import DESIGN_BACK_OFF, StiffnessRequirements

__all__ = ["RobustStiffnessDesign", "robust_design_stiffness", "TOLERANCE_DB"]

TOLERANCE_DB = 1e-6          # the worst case must meet the margin to this (issue 12)
_MAX_OUTER = 25


@dataclass(frozen=True)
class RobustStiffnessDesign:
    status: Literal["optimal", "infeasible", "failed"]
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
    rendered: RenderedFilter | None = None
    """a rendered wall's velocity filter and virtual mass (optim.robust.rendered_stiffness); None: today's wall."""
    solver: SolverInfo = NO_SOLVER
    """the final NLP: Ipopt's return status and iterations, its structure (scenarios, crossovers, cuts)."""
    elapsed_ms: float = 0.0


def _done(t0: float, **kw) -> RobustStiffnessDesign:
    return RobustStiffnessDesign(elapsed_ms=(time.perf_counter() - t0) * 1e3, **kw)


def robust_design_stiffness(nominal: Device, requirements: StiffnessRequirements,
                            box: UncertaintyBox) -> RobustStiffnessDesign:
    """The largest K (and its B) whose gain margin (and passivity, if required) holds for every device of the box."""
    t0 = time.perf_counter()
    req = requirements
    if req.passive_with_quantization:
        raise InputError("requirements.passive_with_quantization", "not available in the robust design (the encoder and friction "
                         "are not parameters of the uncertainty box)")
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
        passivity = PassivityCuts(corners)
    t_min = min(d.sample_time for d in box.devices(box.corners()))
    k_caps, b_caps = req.stiffness_caps(), req.damping_caps(t_min)   # B·q/T ≤ F_noise binds at the smallest T
    k_cap, b_cap = min(k_caps.values(), default=math.inf), min(b_caps.values(), default=math.inf)
    g = req.gain_factor
    scenarios = [scenario_at(box, p) for p in initial_points(box)]
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
        if out.status != "solved":
            return _done(t0, status=out.status, reason=out.reason, iterations=it, ignored_paths=ignored, **pkw,
                         scenarios=tuple(box.describe(sc.point) for sc in scenarios))
        sol, k_nlp, b = out.solution, out.stiffness, out.damping
        last_wc = worst_case_stiffness(box, k_nlp, b, seed=it)
        evals += last_wc.evaluations
        if last_wc.margin_db >= req.min_gain_margin_db - TOLERANCE_DB:
            break
        if any(np.array_equal(last_wc.point, sc.point) for sc in scenarios):
            return _done(t0, status="failed", iterations=it, evaluations=evals, ignored_paths=ignored, **pkw,
                         reason="the worst device is already a scenario but the NLP's design misses its margin")
        scenarios.append(scenario_at(box, last_wc.point))
    else:
        return _done(t0, status="failed", iterations=it, evaluations=evals, ignored_paths=ignored, **pkw,
                     reason=f"the scenario exchange did not settle in {_MAX_OUTER} rounds",
                     scenarios=tuple(box.describe(sc.point) for sc in scenarios))
    return _finish(t0, nominal, box, req, scenarios, sol, k_nlp, b, last_wc, it, evals, ignored, k_caps, b_caps,
                   passivity, pkw)


@dataclass(frozen=True)
class _Round:
    """One round's design over the scenarios: solved, or infeasible (the profile) / failed (the exchange)."""

    status: Literal["solved", "infeasible", "failed"]
    exchange: ExchangeOutcome | None = None
    reason: str | None = None

    @property
    def solution(self):
        return self.exchange.solution

    @property
    def stiffness(self) -> float:
        return self.exchange.stiffness

    @property
    def damping(self) -> float:
        return self.exchange.damping


def _solve_scenarios(scenarios: list[Scenario], g: float, upper_b: float, k_cap: float, b_cap: float,
                     passivity: PassivityCuts | None) -> _Round:
    """The coarse robust profile (stiffness_profile.py), the NLP's seed there (stiffness_seeding.py) and the
    NLP with its inner exchange of crossovers and passivity cuts (stiffness_exchange.py)."""
    profile = coarse_profile(scenarios, g, upper_b, k_cap, passivity)
    if profile.status == "infeasible":
        return _Round("infeasible", reason=profile.reason)
    out = exchange(scenarios, seed(scenarios, profile, g, upper_b, k_cap, b_cap, passivity), g, passivity)
    return _Round(out.status, exchange=out, reason=out.reason)


def _finish(t0, nominal, box, req, scenarios, sol, k_nlp, b, wc: WorstCase, it, evals, ignored, k_caps, b_caps,
            passivity: PassivityCuts | None, pkw: dict) -> RobustStiffnessDesign:
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
    structure = {"scenarios": len(scenarios), "crossovers": [len(t) for t in sol.thetas]}
    if passivity is not None:
        pw = worst_passivity(passivity.corners, k, b)
        c = pw.corner
        pkw = {**pkw, "passivity_delay_samples": c.delay_samples, "passivity_worst_case": {
            "device": box.describe(c.point), "delay_samples_used": c.delay_samples, "approached": c.approached,
            "damping": c.damping, "required_damping": pw.check.required_damping, "passivity_margin": pw.margin,
            "worst_angle": pw.check.worst_angle}}
        structure.update(passivity_corners=len(passivity.corners), passivity_cuts=len(passivity.cuts))
    solver = SolverInfo("ipopt", sol.return_status, sol.iterations, details=(("structure", structure),))
    return _done(t0, status="optimal", stiffness=k, damping=b, gain_margin_db=worst["gain_margin_db"],
                 worst_case=worst, nominal_critical_stiffness=nom, nominal_gain_margin_db=gain_margin_db(nom, k),
                 scenarios=tuple(box.describe(sc.point) for sc in scenarios), iterations=it, evaluations=evals,
                 active_constraints=tuple(active), back_off=DESIGN_BACK_OFF, ignored_paths=ignored, solver=solver,
                 **pkw)
