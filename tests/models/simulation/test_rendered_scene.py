"""A scene's wall with a velocity filter and a virtual mass (models.simulation): the poles of its closed loop (the
filter's states included) agree with the exact K_cr of optim.stability.rendered, the per-sample loop with the exact
recursion, and today's wall is unchanged bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from models.device import Device
from models.errors import InputError
from models.simulation.scene import Scene
from models.simulation.simulate import simulate
from models.velocity_filter import LowPass, MovingAverage, rendering
from optim.stability.rendered import rendered_critical_stiffness

DEV = Device(mass=5.4, damping=3.5, sample_time=1e-3, delay=0.0015)
CABLE = Device.model_validate({"preset": "lhifam", "delay": 0.001})


def _scene(controller: dict, effects: dict | None = None, duration: float = 1.0, velocity: float = 0.0) -> Scene:
    return Scene.model_validate({"experiment": "release", "duration": duration,
                                 "initial": {"position": 0.001, "velocity": velocity},
                                 "controller": controller, "effects": effects or {"delay": {}}})


@pytest.mark.parametrize("device,spec,mass,damping,effects", [
    (DEV, LowPass(kind="low_pass", cutoff_hz=50.0, order=2), -1.0, 5.0, {"delay": {}}),
    (DEV, MovingAverage(kind="moving_average", samples=4), 1.5, 3.0, {"delay": {}}),
    (CABLE, LowPass(kind="low_pass", cutoff_hz=100.0), 0.0, 2.0, {"delay": {}, "cable_mode": {}}),
])
def test_scene_poles_agree_with_the_exact_critical_stiffness(device, spec, mass, damping, effects):
    k = rendered_critical_stiffness(device, damping, rendering(spec, mass, device.sample_time)).critical_stiffness
    ctrl = {"damping": damping, "mass": mass, "velocity_filter": spec.model_dump()}
    below = simulate(device, _scene({**ctrl, "stiffness": k * 0.999}, effects))
    above = simulate(device, _scene({**ctrl, "stiffness": k * 1.001}, effects))
    assert below.judgement.poles.state == "stable" and above.judgement.poles.state == "unstable"
    assert below.verdict.state == "stable" and above.verdict.state == "unstable"


def test_sampled_loop_equals_the_linear_recursion():
    ctrl = {"stiffness": 2000.0, "damping": 5.0, "mass": -1.0,
            "velocity_filter": {"kind": "low_pass", "cutoff_hz": 50.0, "order": 2}}
    rec = simulate(DEV, _scene(ctrl, duration=0.5, velocity=0.01))
    loop = simulate(DEV, _scene(ctrl, {"delay": {}, "quantization": {"resolution": 1e-13}}, 0.5, 0.01))
    assert rec.method == "exact-linear-recursion" and loop.method == "exact-sampled-loop"
    np.testing.assert_allclose(loop.record.motor_position, rec.record.motor_position, rtol=0, atol=1e-12)
    # a 1e-13 m count moves the command by up to |P|·q ≈ (|M|/T²)·1e-13 ≈ 1e-7 N
    np.testing.assert_allclose(loop.record.command, rec.record.command, rtol=0, atol=1e-6)


def test_todays_wall_is_unchanged():
    plain = simulate(DEV, _scene({"stiffness": 3000.0, "damping": 5.0}, duration=0.3, velocity=0.02))
    named = simulate(DEV, _scene({"stiffness": 3000.0, "damping": 5.0, "mass": 0.0,
                                  "velocity_filter": {"kind": "backward_difference"}}, duration=0.3, velocity=0.02))
    assert np.array_equal(plain.record.motor_position, named.record.motor_position)
    assert np.array_equal(plain.record.command, named.record.command)


def test_a_cutoff_above_nyquist_names_the_scene_field():
    with pytest.raises(InputError) as exc:
        simulate(DEV, _scene({"stiffness": 1000.0, "velocity_filter": {"kind": "low_pass", "cutoff_hz": 600.0}}))
    assert exc.value.field == "scene.controller.velocity_filter.cutoff_hz"
