"""The inner exchange of the robust stiffness design: the NLP over the current scenarios, re-checked exactly.

Each solve (problem.py) is followed by the exact analysis of every scenario at the chosen B: a crossover the
NLP did not know (or the Nyquist point) joins that scenario's tracked set, and with passivity the most violated
angle of every corner joins the cuts; the NLP is solved again until nothing is added.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from optim.robust.passivity_cuts import PassivityCuts
from optim.robust.problem import RobustKey, RobustSolution, cut_slots, solve_robust
from optim.robust.stiffness_profile import Scenario
from optim.robust.stiffness_seeding import Seed, piece_bounds
from optim.stability.margins import critical_stiffness

__all__ = ["ExchangeOutcome", "exchange", "MAX_INNER", "MAX_INNER_PASSIVITY"]

MAX_INNER = 12
MAX_INNER_PASSIVITY = 40     # cutting planes converge linearly at a smooth passivity optimum
_VERIFY_RTOL = 1e-8


@dataclass(frozen=True)
class ExchangeOutcome:
    """The NLP's design over the scenarios once the exact re-check adds nothing, or why there is none."""

    status: Literal["solved", "failed"]
    solution: RobustSolution | None = None
    stiffness: float | None = None
    """K [N/m] of the NLP."""
    damping: float | None = None
    """B [N·s/m] of the NLP."""
    reason: str | None = None


def _recheck(scenarios: list[Scenario], thetas, g: float, k: float, b: float) -> bool:
    """Track the NLP's crossovers and add any the exact analysis finds binding at (K, B); True if any was added."""
    changed = False
    for sc, th_nlp in zip(scenarios, thetas):
        sc.crossings = [(t, bb) for t, (_, bb) in zip(th_nlp, sc.crossings)]
        exact = critical_stiffness(sc.device, b, b_max=sc.b_max)
        if k > g * exact.critical_stiffness * (1 + _VERIFY_RTOL) and exact.crossover_frequency is not None:
            th = exact.crossover_frequency * sc.device.sample_time
            if th >= math.pi * (1 - 1e-9):
                if not sc.nyquist:
                    sc.nyquist, changed = True, True
            elif all(abs(th - t) > 1e-7 * th for t, _ in sc.crossings):
                sc.crossings.append((th, piece_bounds(sc.curve, th)))
                changed = True
    return changed


def exchange(scenarios: list[Scenario], start: Seed, g: float, passivity: PassivityCuts | None) -> ExchangeOutcome:
    """Solve, re-check, add, until the exact analysis agrees with the NLP (see the module doc)."""
    k_ref, b_ref = start.k_ref, start.b_ref
    lo, hi = start.b_bounds
    x_kb = list(start.x_kb)
    for _ in range(MAX_INNER if passivity is None else MAX_INNER_PASSIVITY):
        cuts = passivity.rows(k_ref, b_ref) if passivity is not None else None
        key = RobustKey(start.n_states, tuple((len(sc.crossings), sc.nyquist) for sc in scenarios),
                        cut_slots(0 if cuts is None else cuts.shape[0]))
        x0 = np.array(x_kb + [t for sc in scenarios for t, _ in sc.crossings])
        bounds = [bb for sc in scenarios for _, bb in sc.crossings]
        sol = solve_robust(key, start.global_params, list(start.scenario_params), x0, (lo / b_ref, hi / b_ref),
                           bounds, cuts)
        if not sol.success:
            return ExchangeOutcome("failed", reason=f"Ipopt did not converge: {sol.return_status}")
        k, b = sol.k * k_ref, max(sol.b * b_ref, 0.0)
        changed = _recheck(scenarios, sol.thetas, g, k, b)
        if passivity is not None:
            changed |= passivity.exchange(k, b)
        if not changed:
            return ExchangeOutcome("solved", solution=sol, stiffness=k, damping=b)
        x_kb = [sol.k, sol.b]
    return ExchangeOutcome("failed", reason="the exchange of crossovers" + (
        " and passivity angles" if passivity is not None else "") + " did not settle")
