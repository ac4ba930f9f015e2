"""The robust stiffness design's outcomes are typed: infeasible comes from the coarse profile, failed from the
exchange, whatever the reason's wording (issue 19: no status told apart by its message)."""

import numpy as np

from models.device import Device
from optim.robust import stiffness_exchange
from optim.robust.box import UncertaintyBox
from optim.robust.problem import RobustSolution
from optim.robust.stiffness import robust_design_stiffness
from optim.robust.stiffness_profile import coarse_profile, initial_points, scenario_at
from optim.solver_info import plain
from optim.stiffness import StiffnessRequirements

RIGID = Device(preset="lhifam").rigid()
BOX = UncertaintyBox.from_ranges(RIGID, {"device.delay": (0.0, 0.002)})


def _scenarios():
    return [scenario_at(BOX, p) for p in initial_points(BOX)]


def test_profile_without_positive_stiffness_is_infeasible():
    scenarios = _scenarios()
    upper_b = min(sc.b_max for sc in scenarios)
    out = coarse_profile(scenarios, 0.5, upper_b, 0.0, None)          # a zero cap leaves no positive K
    assert out.status == "infeasible" and out.stiffness == 0.0
    found = coarse_profile(scenarios, 0.5, upper_b, np.inf, None)
    assert found.status == "found" and found.stiffness > 0 and 0 <= found.damping < upper_b and found.reason is None


def test_exchange_failure_is_failed_whatever_its_wording(monkeypatch):
    def no_convergence(*args, **kwargs):
        return RobustSolution(False, "no positive Restoration_Failed", 3, 0.0, 0.0, ())
    monkeypatch.setattr(stiffness_exchange, "solve_robust", no_convergence)
    d = robust_design_stiffness(RIGID, StiffnessRequirements(min_gain_margin_db=6.0), BOX)
    # the reason happens to start like the profile's infeasible ones: the status is still the exchange's
    assert d.status == "failed" and d.reason == "Ipopt did not converge: no positive Restoration_Failed"
    assert d.iterations == 1 and len(d.scenarios) == len(initial_points(BOX)) and d.solver.as_json() == {}


def test_solver_record_reads_and_serialises_as_before():
    d = robust_design_stiffness(RIGID, StiffnessRequirements(min_gain_margin_db=6.0), BOX)
    as_json = plain(d)["solver"]
    structure = as_json.pop("structure")
    assert d.status == "optimal" and as_json == {"name": "ipopt", "return_status": "Solve_Succeeded",
                                                 "iterations": d.solver.iterations}
    assert structure["scenarios"] == len(d.scenarios) and len(structure["crossovers"]) == len(d.scenarios)
    assert d.solver["return_status"] == "Solve_Succeeded" and dict(d.solver) == {**as_json, "structure": structure}
