"""optim/scene_verdict.py: a linear wall scene beyond the poles' 600-state limit is decided by K_cr(B), and
that verdict agrees with the independent closed-loop assembly (tests/optim/independent.py, dense)."""

from __future__ import annotations

import pytest

from models.device import Device
from models.simulation.scene import Scene
from models.simulation.scene_poles import MAX_EXACT_STATES
from models.simulation.simulate import simulate
from optim.scene_verdict import margin_verdict, with_margin_verdict
from optim.stability.margins import critical_stiffness
from tests.optim.independent import spectral_radius


def _scene(k: float, b: float = 0.0, **effects) -> Scene:
    return Scene(experiment="release", duration=2.0, controller={"stiffness": k, "damping": b},
                 initial={"position": 1e-3}, effects={"delay": {}} | effects)


@pytest.mark.slow
@pytest.mark.parametrize("delay_samples,cable", [(700, False), (1000, True)])
def test_long_delay_is_decided_by_the_critical_stiffness_and_the_poles_agree(delay_samples, cable):
    dev = Device(preset="lhifam", delay=delay_samples * 1e-3)
    dev = dev if cable else dev.rigid()
    effects = {"cable_mode": {}} if cable else {}
    b = 0.5
    k_cr = critical_stiffness(dev, b).critical_stiffness
    for factor, expected in ((0.9, "stable"), (1.1, "unstable")):
        k = factor * k_cr
        scene = _scene(k, b, **effects)
        res = with_margin_verdict(dev, scene, simulate(dev, scene))
        j = res.judgement
        assert j.poles is None and f"limited to {MAX_EXACT_STATES}" in j.poles_note
        assert res.verdict.state == expected and j.decided_by == "critical stiffness" and j.disagreement is None
        radius = spectral_radius(dev, k * dev.sample_time ** 2 / dev.mass, b * dev.sample_time / dev.mass)
        assert (radius < 1.0) == (expected == "stable")
        assert j.measured.state in (expected, "undetermined")


def test_scenes_outside_the_margins_model_are_left_to_the_measured_verdict():
    dev = Device(preset="lhifam", delay=0.7).rigid()
    assert margin_verdict(dev, _scene(50.0, human={})) is None            # the grasp is not in K_cr's loop
    assert margin_verdict(dev, _scene(0.0)) is None                        # no wall stiffness: z = 1
    k_cr = critical_stiffness(dev).critical_stiffness
    state, reason = margin_verdict(dev, _scene(k_cr))
    assert state == "undetermined" and "within K_cr's accuracy" in reason
    small = Device(preset="lhifam", delay=0.003).rigid()                  # poles decide; unchanged
    res = simulate(small, _scene(1000.0))
    assert with_margin_verdict(small, _scene(1000.0), res) is res and res.judgement.decided_by == "closed-loop poles"
