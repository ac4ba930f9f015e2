"""Issue 17: a simulation's verdict never contradicts the closed-loop poles.

The poles the tests trust come from tests/optim/independent.py (its own assembly of the closed loop)
and optim.stability.margins.critical_stiffness (stable iff K < K_cr(B)); models/simulation/scene_poles.py is what is tested.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from models.device import Device
from models.simulation.oscillation import Verdict
from models.simulation.scene import Scene
from models.simulation.scene_poles import MAX_EXACT_STATES
from models.simulation.simulate import scene_poles, simulate
from models.simulation.verdict import decide
from optim.stability.margins import critical_stiffness
from tests.models.simulation.verdict_cases import random_case, run_case
from tests.optim.independent import spectral_radius
from tests.reference_values import ISSUE17_CABLES, ISSUE17_RIGID

DURATIONS = (0.3, 1.0, 5.0, 20.0)


def _release(dev: Device, k: float, duration: float, b: float = 0.0, **extra) -> Scene:
    eff = {"delay": {}} | ({"cable_mode": {}} if dev.cable is not None else {})
    return Scene(experiment="release", duration=duration, controller={"stiffness": k, "damping": b},
                 initial={"position": 1e-3}, effects=eff | extra)


def _independent_radius(dev: Device, k: float, b: float = 0.0) -> float:
    return spectral_radius(dev, k * dev.sample_time ** 2 / dev.mass, b * dev.sample_time / dev.mass)


def _check(res, dev: Device, k: float, expected: str) -> None:
    v, j = res.verdict, res.judgement
    assert v.state == expected and j.decided_by == "closed-loop poles", v.reason
    # the exact poles against the independent assembly (same matrix up to a similarity: 1e-9)
    assert j.poles.spectral_radius == pytest.approx(_independent_radius(dev, k), rel=1e-9, abs=0)
    assert j.measured.state in (expected, "undetermined"), j.measured.reason
    assert j.disagreement is None


@pytest.mark.parametrize("duration", DURATIONS)
@pytest.mark.parametrize("stiffness,expected", [(20000.0, "unstable"), (6500.0, "stable")])
def test_rigid_lhifam_release_and_its_neighbours(stiffness, expected, duration):
    """The issue's example (2.9 × K_cr, 1 s: the old verdict said stable while 1 mm grew to 1.8 mm) and the
    documented stable wall (0.93 × K_cr) at 0.3, 1, 5 and 20 s."""
    dev = Device(**ISSUE17_RIGID)
    assert (stiffness < critical_stiffness(dev).critical_stiffness) == (expected == "stable")
    res = simulate(dev, _release(dev, stiffness, duration))
    _check(res, dev, stiffness, expected)
    if expected == "unstable" and duration == 1.0:
        xr = res.record.motor_position
        assert np.max(np.abs(xr[-200:])) > 1.7e-3          # the growth the issue saw: 1 → 1.8 mm


@pytest.mark.parametrize("duration", DURATIONS)
@pytest.mark.parametrize("name", sorted(ISSUE17_CABLES))
def test_cable_mode_growing_under_a_decaying_transient(name, duration):
    """1.05 × K_cr: a growing cable mode under a decaying slow transient (the old verdict: stable, at 5 s for
    B and still at 20 s for A).  0.95 × K_cr beside it is stable."""
    dev = Device(**ISSUE17_CABLES[name])
    crit = critical_stiffness(dev)
    assert 770 < crit.crossover_frequency < 790                  # the cable mode sets K_cr
    for factor, expected in ((1.05, "unstable"), (0.95, "stable")):
        k = factor * crit.critical_stiffness
        res = simulate(dev, _release(dev, k, duration))
        _check(res, dev, k, expected)
        if expected == "unstable":
            pole = res.judgement.poles
            assert pole.dominant_frequency == pytest.approx(crit.crossover_frequency, rel=2e-3)
            assert 1.00002 < pole.spectral_radius < 1.0001
            if duration >= 5.0:
                # the growth of that one mode is measured too, although the envelope decays
                assert res.judgement.measured.state == "unstable", res.judgement.measured.reason
                assert res.judgement.measured.frequency == pytest.approx(crit.crossover_frequency, rel=0.02)


def test_a_contradiction_is_said_and_the_poles_decide():
    dev = Device(**ISSUE17_RIGID)
    poles, _ = scene_poles(dev, _release(dev, 20000.0, 1.0))
    wrong = Verdict("stable", 60.0, 1e-3, -1.0, "made up for the test")
    j = decide(wrong, poles, linear=True)
    assert j.verdict.state == "unstable" and j.decided_by == "closed-loop poles"
    assert "says stable" in j.disagreement and "poles decide" in j.disagreement
    assert decide(Verdict("undetermined", None, 0.0, None, "x"), poles, linear=True).disagreement is None


def test_a_pole_on_the_circle_is_undetermined_not_a_guess():
    dev = Device(**ISSUE17_RIGID)
    k_cr = critical_stiffness(dev).critical_stiffness
    res = simulate(dev, _release(dev, k_cr, 5.0))
    assert res.judgement.poles.state == "marginal" and res.verdict.state == "undetermined"
    assert res.judgement.decided_by == "trajectory" and "poles cannot decide" in res.verdict.reason
    # just off K_cr on either side, decided
    assert simulate(dev, _release(dev, k_cr * (1 - 1e-6), 1.0)).verdict.state == "stable"
    assert simulate(dev, _release(dev, k_cr * (1 + 1e-6), 1.0)).verdict.state == "unstable"


def test_without_wall_stiffness_the_free_position_pole_is_set_aside():
    damped = Device(mass=2.0, damping=1.0)
    res = simulate(damped, Scene(experiment="release", duration=1.0, controller={"stiffness": 0.0, "damping": 5.0},
                                 initial={"velocity": 0.01}))
    assert res.judgement.poles.free_position_pole and res.verdict.state == "stable"
    free = Device(mass=2.0, damping=0.0)           # no damping at all: the velocity pole sits at z = 1 too
    res = simulate(free, Scene(experiment="release", duration=1.0, controller={"stiffness": 0.0},
                               initial={"velocity": 0.01}))
    assert res.judgement.poles.state == "marginal" and res.verdict.state == "undetermined"


def test_a_nonlinear_scene_keeps_its_measured_verdict_with_the_linear_part_as_information():
    dev = Device(**ISSUE17_RIGID)
    res = simulate(dev, _release(dev, 20000.0, 5.0, saturation={"max_force": 1e9}))   # never active
    j = res.judgement
    assert j.decided_by == "trajectory" and j.poles_linearised and j.poles.state == "unstable"
    assert res.verdict == j.measured and res.verdict.state in ("unstable", "undetermined")


def test_a_loop_too_large_for_the_exact_check_says_so():
    dev = Device(mass=5.4, damping=3.5, delay=0.7)
    res = simulate(dev, _release(dev, 50.0, 2.0))
    j = res.judgement
    assert j.poles is None and f"limited to {MAX_EXACT_STATES} states" in j.poles_note
    assert res.verdict.state == "undetermined" and "no exact verdict" in res.verdict.reason


@pytest.mark.slow
def test_random_releases_never_contradict_the_poles():
    """CI size of bench/bench_simulate_verdicts.py (≥ 500 there): rigid and cable, 0.8–1.25 × K_cr, B below
    B_max, 0.3–20 s.  The answer always matches the independent poles; the measured verdict may be
    undetermined, never wrong."""
    rng = np.random.default_rng(20261201)
    start, done, measured_decided = time.perf_counter(), 0, 0
    for i in range(400):
        out = run_case(random_case(rng, cable=bool(i % 2)))
        if out is None:
            continue
        done += 1
        assert out.verdict == out.reference and out.decided_by == "closed-loop poles", out
        assert not out.measured_contradiction, out
        measured_decided += out.measured != "undetermined"
    assert done >= 390 and measured_decided >= 100
    assert time.perf_counter() - start < 120
