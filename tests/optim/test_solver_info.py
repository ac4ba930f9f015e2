"""optim.solver_info: the typed solver record and its JSON (the same object the HTTP answers always carried)."""

from dataclasses import dataclass

from optim.solver_info import NO_SOLVER, SolverInfo, plain


@dataclass(frozen=True)
class _Result:
    status: str
    solver: SolverInfo = NO_SOLVER
    nested: dict | None = None


def test_unset_fields_are_left_out_and_details_follow_in_order():
    s = SolverInfo("ipopt", "Solve_Succeeded", 12, details=(("structure", {"states": 2}), ("polished", "Brent")))
    assert s.as_json() == {"name": "ipopt", "return_status": "Solve_Succeeded", "iterations": 12,
                           "structure": {"states": 2}, "polished": "Brent"}
    assert list(s.as_json()) == ["name", "return_status", "iterations", "structure", "polished"]
    assert NO_SOLVER.as_json() == {} and len(NO_SOLVER) == 0 and NO_SOLVER.get("name") is None


def test_reads_as_its_json_object():
    s = SolverInfo("exact B scan", details=(("why", "Ipopt did not converge"),))
    assert s["why"] == "Ipopt did not converge" and s.get("return_status") is None and dict(s) == s.as_json()


def test_with_details_replaces_in_place_and_from_stats_splits_named_fields():
    s = SolverInfo("a", details=(("x", 1), ("y", 2))).with_details(x=3, z=4)
    assert s.details == (("x", 3), ("y", 2), ("z", 4))
    t = SolverInfo.from_stats(None, {"return_status": "ok", "exchange_rounds": 2, "iterations": 5})
    assert t.name is None and t.return_status == "ok" and t.iterations == 5 and t.details == (("exchange_rounds", 2),)
    assert t.as_json() == {"return_status": "ok", "iterations": 5, "exchange_rounds": 2}


def test_plain_converts_only_the_solver_record():
    r = _Result("optimal", SolverInfo("ipopt", "ok"), {"a": 1.0})
    assert plain(r) == {"status": "optimal", "solver": {"name": "ipopt", "return_status": "ok"}, "nested": {"a": 1.0}}
    assert plain(_Result("failed")) == {"status": "failed", "solver": {}, "nested": None}
