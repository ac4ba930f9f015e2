"""The hardware design's "which cutoff" (free = velocity_filter.cutoff_hz, issue 30)."""

from __future__ import annotations

import warnings

import pytest

from models.device import Device
from optim.errors import InputError
from optim.hardware.design import design_hardware
from optim.hardware.hardware_targets import HardwareTarget
from optim.stiffness.rendered_design import FilterContext, best_damping, low_pass_rendering
from optim.stiffness.requirements import StiffnessRequirements
from optim.verification_hardware import verify_hardware_design

DEV = Device(mass=5.4, damping=3.5, sample_time=0.001)
FREE = "velocity_filter.cutoff_hz"


@pytest.mark.parametrize(("rng", "field"), [((10.0, 500.0), "range.max"), ((50.0, 10.0), "range.min"),
                                            ((1e-4, 100.0), "range.min")])
def test_bad_cutoff_range(rng, field):
    with pytest.raises(InputError) as e:
        design_hardware(DEV, HardwareTarget(stiffness=1e5), FREE, value_range=rng)
    assert e.value.field == field


def test_force_feedforward_target_is_refused():
    with pytest.raises(InputError) as e:
        design_hardware(DEV, HardwareTarget(force_gain=2.0), FREE)
    assert e.value.field == "free"


@pytest.mark.slow
def test_lowest_cutoff_renders_the_target_and_no_lower_one_does():
    warnings.filterwarnings("ignore")
    d = design_hardware(DEV, HardwareTarget(stiffness=1e5, max_damping=200), FREE, points=9,
                        value_range=(10.0, 200.0))
    assert d.status == "optimal" and d.bounded and d.direction == "min"
    req = StiffnessRequirements(max_damping=200)
    ctx = FilterContext(DEV, req, 0.0, {}, req.gain_factor)
    below = best_damping(ctx, low_pass_rendering(1, d.value * 0.99, 1e-3, 0.0))[1]
    above = best_damping(ctx, low_pass_rendering(1, d.value * 1.01, 1e-3, 0.0))[1]
    assert below < 1e5 < above
    assert verify_hardware_design(DEV, FREE, d.value, d.controller).verdict == "confirmed"
