"""Issue 34 on the rendered wall (a velocity filter, a virtual mass): past B_max the rung's "no positive stiffness is
stable" (its K → 0⁺ walk) is decided by the closed loop with the filter's and the mass's states, and a stable band is
reported as for today's wall (optim.stability.stable_band).  Every band is held to an independent closed loop
(tests/optim/stability/rendered_independent.py: its own plant, coefficients and realisation) and to /v1/simulate's
verdicts (the scene's own poles; the long-delay verdict of optim.scene_verdict).

The walls are tests/optim/stability/filter_properties' random walls (seed 5), B just above the rendered B_max."""

from __future__ import annotations

import math

import pytest

from models.device import Device
from models.simulation.scene import Scene
from models.simulation.simulate import simulate
from models.velocity_filter import LowPass, MovingAverage, rendering
from optim.scene_verdict import margin_verdict
from optim.stability.analysis import analyse_stability
from optim.stability.rendered import band_crossings, rendered_max_stable_damping
from optim.verification import verify_analysis
from tests.optim.stability.rendered_independent import rendered_radius

#: (device, filter, M [kg], B [N·s/m], the band [N/m] recorded from the analysis and held below to the closed loop)
BANDS = [
    ({"mass": 0.5748426223419162, "damping": 0.6983568970469846, "sample_time": 0.0003331999217544397, "delay": 0.0,
      "cable": {"motor_mass": 0.1808174682062515, "motor_damping": 0.48816819892562097,
                "body_mass": 0.3940251541356647, "body_damping": 0.2101886981213636,
                "stiffness": 360.1784718822881, "damping": 3.8804953708874854}},
     MovingAverage(kind="moving_average", samples=17), 0.21699231732606106, 233.3361286520532,
     (301662.96563879115, 369005.2781231115)),
    ({"mass": 0.1430669805036204, "damping": 3.918654157914337e-06, "sample_time": 0.007680950754243672,
      "delay": 0.007680950754243672,
      "cable": {"motor_mass": 0.021446428911389138, "motor_damping": 2.9929856685509467e-06,
                "body_mass": 0.12162055159223127, "body_damping": 9.256684893633905e-07,
                "stiffness": 2470.4572764286368, "damping": 0.009551968753593263}},
     LowPass(kind="low_pass", cutoff_hz=25.93599863941369, order=2), 0.0, 2.9799862327762296,
     (0.00047481691748817005, 163.72968892130268)),
]


def _excess(dev, spec, mass, k, b) -> float:
    return rendered_radius(dev, spec, mass, k, b) - 1.0


@pytest.mark.parametrize("case", range(len(BANDS)))
def test_a_band_past_the_rendered_b_max_is_reported_and_holds_in_the_independent_closed_loop(case):
    raw, spec, mass, b, recorded = BANDS[case]
    dev = Device(**raw)
    r = rendering(spec, mass, dev.sample_time)
    assert b > rendered_max_stable_damping(dev, r)
    a = analyse_stability(dev, None, b, rendering=r)
    assert a.critical_stiffness == 0.0 and a.stable_band is not None
    lo, hi = a.stable_band
    assert lo == pytest.approx(recorded[0], rel=1e-6) and hi == pytest.approx(recorded[1], rel=1e-6)
    assert "no positive stiffness is stable" not in a.reason and "stable for" in a.reason
    mid = math.sqrt(lo * hi)
    assert _excess(dev, spec, mass, mid, b) < 0.0
    for edge, inside in ((lo, 1.0), (hi, -1.0)):
        assert _excess(dev, spec, mass, edge * (1 + inside * 1e-4), b) < 0.0
        assert _excess(dev, spec, mass, edge * (1 - inside * 1e-4), b) > 0.0
    # the wall's own label, and verify (the closed loop with the filter's states) confirms it
    for k, expected in ((mid, True), (0.5 * lo, False), (2.0 * hi, False)):
        w = analyse_stability(dev, k, b, rendering=r)
        assert w.stable is expected and w.critical_stiffness == 0.0
        assert verify_analysis(dev, w, (spec, mass)).verdict == "confirmed"
    # /v1/simulate agrees: the scene's own closed-loop poles, and the verdict taken from the analysis (long delays)
    for k, expected in ((mid, "stable"), (2.0 * hi, "unstable")):
        scene = Scene(experiment="release", duration=0.05, initial={"position": 1e-3},
                      controller={"stiffness": k, "damping": b, "mass": mass, "velocity_filter": spec.model_dump()},
                      effects={"delay": {}, "cable_mode": {}})
        assert simulate(dev, scene).verdict.state == expected
        state, why = margin_verdict(dev, scene)
        assert state == expected and "by the closed loop" in why


def test_no_stable_k_past_the_rendered_b_max_is_confirmed_interval_by_interval():
    """A rigid device with a first-order low-pass, B 1e-4 above its B_max: no band; the analysis says the closed
    loop confirms it, and the independent closed loop is unstable below, between and above every crossover."""
    dev = Device(mass=1.0, damping=0.5, sample_time=1e-3, delay=2e-3)
    spec = LowPass(kind="low_pass", cutoff_hz=50.0, order=1)
    r = rendering(spec, 0.2, dev.sample_time)
    b = rendered_max_stable_damping(dev, r) * (1 + 1e-4)
    a = analyse_stability(dev, 10.0, b, rendering=r)
    assert a.critical_stiffness == 0.0 and a.stable_band is None and a.stable is False
    assert "closed loop confirms" in a.reason
    ks = sorted({c[0] * dev.stiffness_scale for c in band_crossings(dev, r, b * dev.sample_time / dev.mass)})
    tests = [0.5 * ks[0]] + [math.sqrt(x * y) for x, y in zip(ks, ks[1:])] + [2.0 * ks[-1]]
    assert all(_excess(dev, spec, 0.2, k, b) > 0.0 for k in tests)


@pytest.mark.slow
@pytest.mark.parametrize("i", range(6))
def test_rendered_walls_near_b_max_property_sample(i):
    """6 cases of the docs/properties_analysis.md run (seed 34): each claim held to the independent closed loop."""
    from tests.optim.stability.rendered_band_cases import one_case

    r = one_case(34, i)
    assert r.get("ok") is not False, r
