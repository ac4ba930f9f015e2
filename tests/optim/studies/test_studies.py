"""optim.studies.problems: sweeps, points, hashes and the problem registry (no I/O)."""

from __future__ import annotations

import math
import sys
import types
from dataclasses import dataclass, field

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydantic import BaseModel, ConfigDict

from models.device import Device
from optim.stability.analysis import analyse_stability
from optim.studies import problems as studies
from optim.studies.problems import (
    MAX_STUDY_POINTS,
    StudyInputError,
    evaluate_chunk,
    evaluate_point,
    flatten_result,
    get_problem,
    plan_study,
)
from tests.reference_values import CASES

RIGID = {"mass": 5.4, "damping": 3.5, "sample_time": 0.001}


def _rows(plan):
    return list(enumerate(plan.values(0, plan.total).tolist()))


def test_grid_is_the_cartesian_product_in_row_major_order():
    plan = plan_study("stability", RIGID, {}, {"device.delay": {"start": 1e-4, "stop": 1e-2, "num": 3, "scale": "log"},
                                               "requirements.damping": [0.0, 1.0], "device.mass": [1.0, 2.0, 4.0]})
    assert plan.total == 18
    vals = plan.values(0, 18)
    assert vals.shape == (18, 3)
    assert vals[:, 0].tolist() == [pytest.approx(v, rel=1e-15) for v in [1e-4] * 6 + [1e-3] * 6 + [1e-2] * 6]
    assert vals[:6, 2].tolist() == [1.0, 2.0, 4.0, 1.0, 2.0, 4.0] and vals[:6, 1].tolist() == [0, 0, 0, 1, 1, 1]
    assert len({tuple(r) for r in vals.tolist()}) == 18
    assert np.array_equal(plan.values(5, 9), vals[5:9])  # any slice of the plan is the same points


@settings(max_examples=25, deadline=None)
@given(samples=st.integers(1, 300), seed=st.integers(0, 2**32), lo=st.floats(1e-6, 1e-3), decades=st.floats(0.5, 4))
def test_latin_hypercube_has_one_sample_per_stratum(samples, seed, lo, decades):
    hi = lo * 10**decades
    plan = plan_study("stability", RIGID, {}, {"device.delay": {"start": lo, "stop": hi, "scale": "log"},
                                               "device.damping": {"start": 1.0, "stop": 3.0}},
                      {"design": "latin_hypercube", "samples": samples, "seed": seed})
    vals = plan.values(0, samples)
    u_delay = np.log(vals[:, 0] / lo) / math.log(hi / lo)
    u_damp = (vals[:, 1] - 1.0) / 2.0
    for u in (u_delay, u_damp):
        # a sample lands within ~1e-15 of a stratum edge with negligible probability: exact strata
        assert sorted(np.floor(u * samples).astype(int).tolist()) == list(range(samples))
    assert np.array_equal(vals, plan_study("stability", RIGID, {}, {"device.delay": {"start": lo, "stop": hi, "scale": "log"},
                                                                    "device.damping": {"start": 1.0, "stop": 3.0}},
                                           {"design": "latin_hypercube", "samples": samples, "seed": seed}).values(0, samples))


def test_stability_points_are_the_exact_analysis():
    plan = plan_study("stability", RIGID, {"stiffness": 2000.0},
                      {"device.delay": [0.0, 0.0005, 0.002], "requirements.damping": [0.0, 3.0]})
    out = evaluate_chunk(plan.problem, plan.device, plan.requirements, [(a.path, a.kind) for a in plan.axes], _rows(plan))
    assert [o[0] for o in out] == list(range(6)) and all(o[3] is None for o in out)
    for index, (delay, b), result, _ in out:
        direct = analyse_stability(Device(**RIGID, delay=delay), 2000.0, b)
        # the study's vectorised path (optim.studies.stability_study) against the one-point analysis: the exact rung's 1e-12
        assert result["critical_stiffness"] == pytest.approx(direct.critical_stiffness, rel=1e-12, abs=0.0)
        assert result["gain_margin_db"] == pytest.approx(direct.gain_margin_db, rel=0.0, abs=1e-10)
        assert result["stable"] == direct.stable and result["passive"] == direct.passive
        assert "elapsed_ms" not in result  # a stored point holds no wall-clock time
    k = {(d, b): r["critical_stiffness"] for _, (d, b), r, _ in out}
    assert k[0.0, 0.0] > k[0.0005, 0.0] > k[0.002, 0.0]  # delay only lowers K_cr
    case = CASES["table3-lhifam-rigid"]  # chapter Table 3, 76.9 dB
    assert 20 * math.log10(k[0.0, 0.0]) == pytest.approx(case["printed"], abs=case["tolerance_db"])


def test_a_bad_point_fails_alone():
    result, error = evaluate_point("stability", {**RIGID, "delay": 50.0}, {})
    assert result is None and "delay" in error


@pytest.mark.parametrize("sweep, field", [
    ({"device.nope": [1.0]}, "sweep.device.nope"),
    ({"device.mass": []}, "sweep.device.mass"),
    ({"device.mass": [1.0, math.inf]}, "sweep.device.mass.1"),
    ({"device.mass": {"start": 1, "stop": 2, "num": 0}}, "sweep.device.mass.num"),
    ({"device.mass": {"start": 1, "stop": 2, "num": 3, "scale": "exp"}}, "sweep.device.mass.scale"),
    ({"device.mass": {"start": 1, "stop": 2, "num": 3, "step": 1}}, "sweep.device.mass.step"),
    ({"device.mass": {"start": 1, "stop": 2, "num": MAX_STUDY_POINTS}, "device.damping": [1.0, 2.0]}, "sweep"),
    ({"device.mass": [0.0]}, "sweep.device.mass"),
    ({"requirements.stiffness": [-1.0]}, "sweep.requirements.stiffness"),
])
def test_bad_sweeps_name_the_field(sweep, field):
    with pytest.raises(StudyInputError) as exc:
        plan_study("stability", RIGID, {}, sweep)
    assert exc.value.field == field


def test_unknown_problem_and_requirements():
    with pytest.raises(StudyInputError, match="unknown problem"):
        get_problem("haptics")
    with pytest.raises(StudyInputError) as exc:
        plan_study("stability", RIGID, {"stifness": 1.0}, {"device.mass": [1.0]})
    assert exc.value.field == "base.requirements.stifness"


def test_flatten_drops_timings_and_non_finite():
    @dataclass(frozen=True)
    class R:
        k: float = math.inf
        ok: bool = True
        names: tuple = ("a", "b")
        items: tuple = (1, 2, 3, 4, 5)
        band: tuple = (10.0, 80.0)
        solver: dict = field(default_factory=lambda: {"return_status": "Solve_Succeeded", "t_wall_total": 0.1})
        elapsed_ms: float = 3.0
    assert flatten_result(R()) == {"k": None, "ok": True, "names": "a;b", "n_items": 5, "band.0": 10.0, "band.1": 80.0,
                                   "solver.return_status": "Solve_Succeeded"}


def test_design_problems_register_lazily(monkeypatch):
    """A design module that is present is used as is; an integer requirement takes whole numbers only."""
    class Req(BaseModel):   # a requirements model, as optim's (frozen pydantic)
        model_config = ConfigDict(frozen=True)
        min_gain_margin_db: float = 6.0
        filter_order: int = 2

    @dataclass(frozen=True)
    class Design:
        status: str
        force_gain: float

    def design_inertia(device, req):
        return Design("optimal", device.mass * req.filter_order / 10 ** (req.min_gain_margin_db / 20))

    fake = types.ModuleType("optim.transparency.inertia")
    fake.design_inertia, fake.InertiaRequirements = design_inertia, Req
    monkeypatch.setitem(sys.modules, "optim.transparency.inertia", fake)
    monkeypatch.setattr(studies, "_CACHE", {})
    plan = plan_study("inertia", RIGID, {}, {"requirements.filter_order": [1, 2], "requirements.min_gain_margin_db": [0.0]})
    out = evaluate_chunk(plan.problem, plan.device, plan.requirements, [(a.path, a.kind) for a in plan.axes], _rows(plan))
    assert [o[2] for o in out] == [{"status": "optimal", "force_gain": 5.4}, {"status": "optimal", "force_gain": 10.8}]
    with pytest.raises(StudyInputError) as exc:
        plan_study("inertia", RIGID, {}, {"requirements.filter_order": [1.5]})
    assert exc.value.field == "sweep.requirements.filter_order"
    monkeypatch.setitem(sys.modules, "optim.transparency.inertia", None)
    monkeypatch.setattr(studies, "_CACHE", {})
    with pytest.raises(StudyInputError, match="not available in this build"):
        get_problem("inertia")


def test_point_builder_equals_the_one_point_form():
    """The runner's bulk builder (issue 20) gives exactly the one-point inputs, and points never share a mutable
    branch (a cable sweep copies the cable dict per point, the base stays untouched)."""
    from optim.studies.problems import point_builder

    base = {"preset": "lhifam", "cable": {"stiffness": 5e4}}
    plan = plan_study("stability", base, {"stiffness": 1000.0},
                      {"device.cable.stiffness": [3e4, 8e4, 3e4], "requirements.damping": [0.0, 2.5],
                       "device.delay": {"start": 0.0, "stop": 0.002, "num": 3}})
    values = plan.values(0, plan.total).tolist()
    build = point_builder(plan.device, plan.requirements, [(a.path, a.kind) for a in plan.axes])
    built = [build(v) for v in values]
    for (dev, req), v in zip(built, values):
        assert dev["cable"]["stiffness"] == v[0] and req["damping"] == v[1] and dev["delay"] == v[2]
        assert dev["preset"] == "lhifam" and req["stiffness"] == 1000.0
    assert len({id(dev["cable"]) for dev, _ in built}) == len(built)
    assert plan.device == base and base["cable"] == {"stiffness": 5e4}


def test_the_total_limit_is_the_callers():
    """A deployment may raise the study size (ZWIDTH_STUDY_MAX_POINTS, issue 20's 10-million-point study);
    the default stays MAX_STUDY_POINTS and the refusal names the sweep."""
    from optim.studies.problems import MAX_STUDY_POINTS, StudyInputError

    sweep = {"device.mass": {"start": 1.0, "stop": 2.0, "num": 1000}, "device.delay": [0.0, 0.001, 0.002]}
    assert plan_study("critical_stiffness", RIGID, {}, sweep, max_points=3000).total == 3000
    with pytest.raises(StudyInputError) as err:
        plan_study("critical_stiffness", RIGID, {}, sweep, max_points=2999)
    assert err.value.field == "sweep" and "2999" in err.value.rule
    big = {"device.mass": {"start": 1.0, "stop": 2.0, "num": MAX_STUDY_POINTS}, "device.delay": [0.0, 0.001]}
    with pytest.raises(StudyInputError):
        plan_study("critical_stiffness", RIGID, {}, big)
    assert plan_study("critical_stiffness", RIGID, {}, big, max_points=2 * MAX_STUDY_POINTS).total == 2 * MAX_STUDY_POINTS


@pytest.mark.parametrize("device, sweep, field", [
    ({**RIGID, "encoder_resolution": 1e-5}, {"device.mass": [1.0, 2.0]}, "base.device.encoder_resolution"),
    ({**RIGID, "coulomb_friction": 0.1}, {"device.mass": [1.0, 2.0]}, "base.device.coulomb_friction"),
    (RIGID, {"device.encoder_resolution": [1e-5, 2e-5]}, "sweep.device.encoder_resolution"),
])
def test_studies_refuse_what_they_would_ignore(device, sweep, field):
    # issue 31: the studies analyse the linear loop; an encoder or a friction is refused, never silently dropped
    with pytest.raises(StudyInputError) as exc:
        plan_study("stability", device, {}, sweep)
    assert exc.value.field == field


def test_with_delay_is_model_copy_with_the_delay():
    """models.device.with_delay (issue 32: a study point's device, copied with its delay) makes what
    model_copy(update={"delay": …}) makes: the same fields (nested blocks shared, as its shallow copy shares them),
    fields set, extra and private state, equality, hash and dump; the original is unchanged."""
    from models.device import Device, with_delay

    for dev in (Device(mass=5.4, damping=3.5), Device(preset="lhifam", delay=0.002),
                Device.model_validate(Device(preset="lhifam").model_dump(exclude={"preset"}))):
        before = dev.model_dump()
        for delay in (0.0, 0.0037, 0.02):
            got, want = with_delay(dev, delay), dev.model_copy(update={"delay": delay})
            assert type(got) is type(want)
            assert got.__dict__ == want.__dict__ and all(got.__dict__[k] is want.__dict__[k] for k in got.__dict__)
            assert got.__pydantic_fields_set__ == want.__pydantic_fields_set__
            assert (got.__pydantic_extra__, got.__pydantic_private__) == (want.__pydantic_extra__,
                                                                          want.__pydantic_private__)
            assert got == want and hash(got) == hash(want) and got.model_dump() == want.model_dump()
            assert got.delay == delay and got.delay_samples == want.delay_samples
            assert got.__pydantic_fields_set__ is not dev.__pydantic_fields_set__
        assert dev.model_dump() == before
