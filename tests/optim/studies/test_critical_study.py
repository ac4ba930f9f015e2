"""The vectorised ``critical_stiffness`` study problem against the per-point exact analysis.

Independent method: ``optim.stability.analysis.analyse_stability`` / ``optim.stability.margins`` evaluate one device at
a time with their own scan grid (optim.stability.crossovers.scan_grid) and refinement; the problem evaluates a
whole chunk in the arrays of ``optim.robust.batch``.  rtol=1e-12 is the accuracy the exact rung
claims (optim.stability.analysis.EXACT_REL_ERROR); measured agreement is ~1e-15 (different arithmetic order).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from models.device import Device
from optim.stability.analysis import analyse_stability
from optim.stability.margins import max_stable_damping
from optim.studies import critical_study
from optim.studies.problems import evaluate_chunk, evaluate_point, get_problem, plan_study

RTOL = 1e-12  # the exact rung's stated relative error; both sides refine every crossover to a few ulp
RIGID = {"mass": 5.4, "damping": 3.5, "sample_time": 0.001}  # chapter Table 2 (rigid LHifAM)


def _rows(plan):
    return list(enumerate(plan.values(0, plan.total).tolist()))


def _assert_matches_analysis(dev: Device, req: dict, got: dict) -> None:
    k, b = req.get("stiffness"), float(req.get("damping") or 0.0)
    ref = analyse_stability(dev, k, b, "exact")
    assert got["critical_stiffness"] == pytest.approx(ref.critical_stiffness, rel=RTOL, abs=0.0)
    if ref.crossover_frequency is None:
        assert got["crossover_frequency"] is None
    else:
        assert got["crossover_frequency"] == pytest.approx(ref.crossover_frequency, rel=RTOL, abs=0.0)
    # the stability problem reports B_max only for B > 0; here it is computed at every B
    bmax = max_stable_damping(dev)
    assert got["max_stable_damping"] == (pytest.approx(bmax, rel=RTOL, abs=0.0) if math.isfinite(bmax) else None)
    # eq. 10 by hand, independent of optim: (b + B)/(T/2 + t_d), one rounding each
    assert got["linear_estimate"] == pytest.approx((dev.damping + b) / (dev.sample_time / 2 + dev.delay), rel=1e-15)
    assert got["reason"] == ref.reason or (got["reason"] and ref.reason and got["reason"][:40] == ref.reason[:40])
    if k is None:
        assert "stable" not in got and "gain_margin_db" not in got
    else:
        assert got["stable"] == ref.stable
        if ref.gain_margin_db is None:
            assert got["gain_margin_db"] is None
        else:
            # 20·log10 of a ratio that agrees to RTOL: the margin agrees to 20/ln10·RTOL dB absolute
            assert got["gain_margin_db"] == pytest.approx(ref.gain_margin_db, rel=0.0, abs=1e-10)


def test_mixed_rigid_and_cable_chunk_matches_the_stability_analysis():
    """Rigid and cable devices in one chunk, whole and fractional delays, B from 0 to past B_max."""
    lh = Device(preset="lhifam")
    devices, reqs = [], []
    for i, ds in enumerate([0.0, 1.0, 2.5, 3.7, 0.4]):
        t = 0.001
        rigid = Device(**RIGID, delay=ds * t)
        cable = lh.model_copy(update={"delay": ds * t,
                                      "cable": lh.cable.model_copy(update={"stiffness": 2e4 * 3 ** i})})
        for dev in (rigid, cable):
            for frac in (0.0, 0.3, 1.2):  # B = 1.2·B_max: K_cr = 0 with the reason
                devices.append(dev)
                reqs.append({"damping": frac * max_stable_damping(dev), "stiffness": 1500.0} if frac
                            else {"stiffness": 1500.0} if i % 2 else {})
    devices.append(Device(mass=1.0, damping=0.0, sample_time=0.001))  # no damping at all: K_cr = 0
    reqs.append({"stiffness": 10.0})
    out = get_problem("critical_stiffness").evaluate_batch(devices, reqs)
    assert len(out) == len(devices) and all(err is None for _, err in out)
    kcr = [r["critical_stiffness"] for r, _ in out]
    assert sum(k == 0.0 for k in kcr) == 11 and sum(k > 0 for k in kcr) == 20
    for dev, req, (got, _) in zip(devices, reqs, out):
        _assert_matches_analysis(dev, req, got)


@pytest.mark.parametrize("base, sweep", [
    (RIGID, {"device.delay": [0.0, 0.0007, 0.002], "requirements.damping": [0.0, 3.0, 40.0]}),
    ({"preset": "lhifam"}, {"device.cable.stiffness": {"start": 2e4, "stop": 2e5, "num": 3, "scale": "log"},
                            "device.delay": [0.0, 0.0013], "requirements.damping": [0.0, 5.0]}),
])
def test_study_chunk_matches_the_stability_problem(base, sweep):
    plan = plan_study("critical_stiffness", base, {"stiffness": 2000.0}, sweep)
    axes = [(a.path, a.kind) for a in plan.axes]
    fast = evaluate_chunk("critical_stiffness", plan.device, plan.requirements, axes, _rows(plan))
    full = evaluate_chunk("stability", plan.device, plan.requirements, axes, _rows(plan))
    assert [f[:2] for f in fast] == [f[:2] for f in full]  # same points, same order
    for (_, values, got, err), (_, _, ref, _) in zip(fast, full):
        assert err is None
        dev, req = plan.inputs(values)
        _assert_matches_analysis(Device.model_validate(dev), req, got)
        assert got["critical_stiffness"] == pytest.approx(ref["critical_stiffness"], rel=RTOL, abs=0.0)


def test_invalid_points_fail_alone():
    """A delay beyond 10,000 samples is invalid only with the small sample time: those points fail, the rest run."""
    plan = plan_study("critical_stiffness", RIGID, {}, {"device.delay": [0.0, 0.0004, 0.02],
                                                        "device.sample_time": [0.001, 1e-6]})
    out = evaluate_chunk("critical_stiffness", plan.device, plan.requirements,
                         [(a.path, a.kind) for a in plan.axes], _rows(plan))
    failed = {tuple(o[1]): o[3] for o in out if o[3] is not None}
    assert list(failed) == [(0.02, 1e-6)] and "delay" in failed[0.02, 1e-6] and "invalid device" in failed[0.02, 1e-6]
    for _, values, got, err in out:
        if err is None:
            _assert_matches_analysis(Device.model_validate(plan.inputs(values)[0]), {}, got)
    result, error = evaluate_point("critical_stiffness", {**RIGID, "delay": 50.0}, {})
    assert result is None and "delay" in error


def test_a_point_that_raises_fails_alone(monkeypatch):
    """The batch is split down to the device that raises; its neighbours keep their exact answers."""
    real = critical_study.critical_arrays
    poison = 0.0011

    def flaky(devices, damping):
        if any(d.delay == poison for d in devices):
            raise FloatingPointError("overflow in the scan")
        return real(devices, damping)

    monkeypatch.setattr(critical_study, "critical_arrays", flaky)
    delays = [0.0, 0.0005, poison, 0.0015, 0.0002]
    devices = [Device(**RIGID, delay=d) for d in delays]
    out = critical_study.evaluate_batch(devices, [{}] * len(devices))
    assert [err for _, err in out] == [None, None, "FloatingPointError: overflow in the scan", None, None]
    for dev, (got, err) in zip(devices, out):
        if err is None:
            _assert_matches_analysis(dev, {}, got)


def test_requirements_are_checked_per_point():
    with pytest.raises(Exception) as exc:
        plan_study("critical_stiffness", RIGID, {"stiffness": -1.0}, {"device.delay": [0.0]})
    assert getattr(exc.value, "field", None) == "base.requirements.stiffness"
    result, error = evaluate_point("critical_stiffness", RIGID, {"damping": -1.0})
    assert result is None and "damping" in error
    result, error = evaluate_point("critical_stiffness", RIGID, {"stiffness": 1500.0})
    assert error is None
    _assert_matches_analysis(Device(**RIGID), {"stiffness": 1500.0}, result)
    assert np.isfinite(result["gain_margin_db"]) and result["stable"] is True
