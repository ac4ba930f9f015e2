"""The vectorised ``stability`` study problem (optim.studies.stability_study) against the one-point exact analysis.

Independent method: ``optim.stability.analysis.analyse_stability`` evaluates one device at a time (its own scan grid,
optim.stability.crossovers, and a bounded Brent search for passivity); the study path evaluates a whole chunk in the
arrays of ``optim.robust.batch`` and ``optim.stability.passivity.batch_required_damping``.  RTOL is the accuracy the
exact rung claims; the measured agreement is ~1e-15.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from models.device import Device
from optim.stability.analysis import analyse_stability
from optim.stability.margins import max_stable_damping
from optim.stability.passivity import batch_required_damping, passivity_margin
from optim.studies import stability_study
from optim.studies.problems import evaluate_chunk, plan_study

RTOL = 1e-12
RIGID = {"mass": 5.4, "damping": 3.5, "sample_time": 0.001}  # chapter Table 2 (rigid LHifAM)


def _close(got, ref, rel=RTOL):
    if ref is None:
        assert got is None
    else:
        assert got == pytest.approx(ref, rel=rel, abs=0.0)


def _assert_matches(dev: Device, req: dict, got: dict) -> None:
    k, b = req.get("stiffness"), float(req.get("damping") or 0.0)
    ref = analyse_stability(dev, k, b, "exact")
    _close(got["critical_stiffness"], ref.critical_stiffness)
    _close(got["crossover_frequency"], ref.crossover_frequency)
    assert got["stable"] == ref.stable
    if ref.gain_margin_db is None:
        assert got["gain_margin_db"] is None
    else:
        assert got["gain_margin_db"] == pytest.approx(ref.gain_margin_db, rel=0.0, abs=1e-10)
    # passivity: sup of P(θ) to the accuracy of the two searches, relative to the size of P's terms
    if k is None:
        assert got["passive"] is None and got["passivity_required_damping"] is None
    else:
        d = got["passivity_required_damping"]
        scale = k * dev.sample_time / 2 * (2 * math.ceil(dev.delay_samples - 1e-12) + 1) + b
        assert abs(d - ref.passivity_required_damping) <= 1e-12 * scale
        assert got["passive"] == ref.passive or abs(dev.damping - d) <= 1e-12 * scale
        assert got["passivity_conservative"] == ref.passivity_conservative
    _close(got["linear_estimate"], ref.linear_estimate, rel=1e-15)
    _close(got["linear_error"], ref.linear_error, rel=1e-9)      # |lin/K_cr − 1| amplifies K_cr's 1e-12
    bmax = max_stable_damping(dev)                                # given at every B (the analysis: B > 0 only)
    _close(got["max_stable_damping"], bmax if math.isfinite(bmax) else None)
    _close(got["q_criterion"], ref.q_criterion, rel=1e-15)
    _close(got["rigid_critical_stiffness"], ref.rigid_critical_stiffness)
    assert got["mode_matters"] == ref.mode_matters
    assert got["reason"] == ref.reason or (got["reason"][:40] == ref.reason[:40])
    assert got["error_estimate"] == ref.error_estimate


@pytest.mark.slow
def test_mixed_chunk_matches_the_one_point_analysis():
    """Rigid and cable devices, whole and fractional delays, B from 0 to past B_max, with and without a wall."""
    lh, ph = Device(preset="lhifam"), Device(preset="phantom-1.0")
    devices, reqs = [], []
    for i, ds in enumerate([0.0, 1.0, 2.5, 3.7, 0.4]):
        for dev in (lh.rigid(), lh, ph):
            d = dev.model_copy(update={"delay": ds * dev.sample_time})
            bmax = max_stable_damping(d)
            kcr0 = analyse_stability(d).critical_stiffness
            for b in (0.0, 0.3 * bmax, 1.2 * bmax):
                for k in (None, 0.02 * kcr0, 0.5 * kcr0, 2 * kcr0):
                    devices.append(d)
                    reqs.append({"damping": b} if k is None else {"damping": b, "stiffness": k})
    out = stability_study.evaluate_batch(devices, reqs)
    assert all(err is None for _, err in out)
    kinds = {(r.get("stiffness") is None, got["passive"], got["stable"]) for r, (got, _) in zip(reqs, out)}
    assert {(False, True, True), (False, False, True), (False, False, False), (True, None, None)} <= kinds
    for dev, req, (got, _) in zip(devices, reqs, out):
        _assert_matches(dev, req, got)


def test_a_point_alone_equals_the_point_in_a_chunk():
    """Resumed studies put points in other chunks: a row must not depend on its neighbours, bit for bit."""
    plan = plan_study("stability", {"preset": "lhifam"}, {"stiffness": 3000.0},
                      {"device.delay": [0.0, 0.0004, 0.0013, 0.0031], "requirements.damping": [0.0, 4.0, 30.0],
                       "device.cable.stiffness": [3e4, 8e4]})
    axes = [(a.path, a.kind) for a in plan.axes]
    rows = list(enumerate(plan.values(0, plan.total).tolist()))
    whole = evaluate_chunk("stability", plan.device, plan.requirements, axes, rows)
    odd = evaluate_chunk("stability", plan.device, plan.requirements, axes, rows[1::2])
    single = [evaluate_chunk("stability", plan.device, plan.requirements, axes, [r])[0] for r in rows[::5]]
    by_index = {o[0]: o for o in whole}
    for o in odd + single:
        assert o == by_index[o[0]]


@pytest.mark.parametrize("d", [0, 1, 3, 12])
def test_batch_passivity_equals_the_bounded_search(d):
    rng = np.random.default_rng(d)
    dev = Device(**RIGID, delay=d * 0.001)
    k = rng.uniform(10, 5e4, 40)
    b = np.concatenate([np.zeros(10), rng.uniform(0, 200, 30)])
    got, angle = batch_required_damping(d, k * dev.sample_time / 2, b)
    for ki, bi, gi, ai in zip(k, b, got, angle):
        ref = passivity_margin(dev, float(ki), float(bi))
        scale = ki * dev.sample_time / 2 * (2 * d + 1) + bi
        # both are proven upper bounds of the sup (issue 34), each within its own error bound of it
        assert abs(gi - ref.required_damping) <= 1e-13 * scale + ref.error_bound
        assert 0.0 <= ai <= math.pi
    # the closed-form limits: B = 0 → K(T/2 + t_d) at θ → 0 (ARCHITECTURE.md), d = 0 → KT/2 + B (eq. 3)
    k0 = np.array([1000.0, 7000.0])
    np.testing.assert_allclose(batch_required_damping(d, k0 * 0.0005, np.zeros(2))[0], k0 * (0.0005 + d * 0.001),
                               rtol=1e-14)
    if d == 0:
        np.testing.assert_allclose(batch_required_damping(0, k0 * 0.0005, np.array([5.0, 9.0]))[0],
                                   k0 * 0.0005 + np.array([5.0, 9.0]), rtol=1e-14)


def test_a_cable_grid_study_matches_the_one_point_analysis():
    """Issue 32's cable grid (cable stiffness × delay × cable damping on the lhifam preset, a wall K and B) through
    evaluate_chunk: the points that differ only in their delay share one validated device and one sampled plant per
    fractional part (optim.studies.problems, optim.stability.cable_batch's groups); each row is still the one-point
    exact analysis of its own device, the rows past half of B_max (handed to margins) included."""
    plan = plan_study("stability", {"preset": "lhifam"}, {"stiffness": 1500.0, "damping": 2.0},
                      {"device.cable.stiffness": [3e4, 1.1e5], "device.delay": [0.0, 0.002, 0.0035, 0.012, 0.02],
                       "device.cable.damping": [2.0, 30.0]})
    axes = [(a.path, a.kind) for a in plan.axes]
    rows = list(enumerate(plan.values(0, plan.total).tolist()))
    out = evaluate_chunk("stability", plan.device, plan.requirements, axes, rows)
    assert all(err is None for *_, err in out)
    near = 0
    for (_, values), (_, _, got, _) in zip(rows, out):
        dev_in, req = plan.inputs(values)
        dev = Device.model_validate(dev_in)
        _assert_matches(dev, req, got)
        near += got["max_stable_damping"] is not None and 2.0 > 0.5 * got["max_stable_damping"]
    assert near > 0          # some rows are past half of B_max: margins' own path (the 40-digit screen) answers them
