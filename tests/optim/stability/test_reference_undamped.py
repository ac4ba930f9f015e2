"""The reference rung without physical damping (optim.stability.reference).

A frictionless device (b = 0) is valid input; the reference rung answered every such request with a 422
"outside the numerically representable range (float division by zero)": its rigid closed form divides by δ, and
its scan started its grid at a frequency ∝ δ.  Now 1/s² has its own modified z-transform, K_cr = 0 without any
damping (δ = β = 0), and a cable with every damping 0 and B > 0 (its mode on the unit circle) is refused on
``device.cable`` rather than scanned for 30 s.  Checks: the exact rung (a second algorithm), the δ → 0 limit of
the δ > 0 closed form (the same rung, another formula), and the closed loop's spectral radius.
"""

from __future__ import annotations

import pytest

from models.device import Device
from optim.errors import InputError
from optim.stability.margins import critical_stiffness
from optim.stability.reference import reference_critical_stiffness
from tests.optim.independent import spectral_radius

CABLE = dict(motor_mass=0.3, motor_damping=0.0, body_mass=5.1, body_damping=0.0, stiffness=79500.0)


@pytest.mark.slow
@pytest.mark.parametrize("delay", [0.0, 1e-3, 2.5e-3, 7.3e-3])
@pytest.mark.parametrize("damping", [0.5, 20.0])
def test_frictionless_rigid_reference_agrees_with_exact_and_the_delta_limit(delay, damping):
    dev = Device(mass=5.4, damping=0.0, sample_time=1e-3, delay=delay)
    ref = reference_critical_stiffness(dev, damping, digits=25)
    assert ref.critical_stiffness == pytest.approx(critical_stiffness(dev, damping).critical_stiffness, rel=1e-12)
    # δ = 1e-16 goes through the δ > 0 partial fractions: K_cr moves by about δ/β ≤ 2e-12 relative
    near = reference_critical_stiffness(dev.model_copy(update={"damping": 5.4e-13}), damping, digits=25)
    assert ref.critical_stiffness == pytest.approx(near.critical_stiffness, rel=1e-10)
    alpha, beta = ref.critical_stiffness * 1e-6 / 5.4, damping * 1e-3 / 5.4        # K T²/m, B T/m
    assert spectral_radius(dev, 0.999 * alpha, beta) < 1 < spectral_radius(dev, 1.001 * alpha, beta)


@pytest.mark.parametrize("cable_damping", [None, 0.0, 15.0])
def test_no_damping_at_all_gives_zero(cable_damping):
    cable = None if cable_damping is None else {**CABLE, "damping": cable_damping}
    dev = Device(mass=5.4, damping=0.0, sample_time=1e-3, delay=1e-3, cable=cable)
    assert reference_critical_stiffness(dev, 0.0).critical_stiffness == 0.0
    assert critical_stiffness(dev, 0.0).critical_stiffness == 0.0
    assert spectral_radius(dev, 1e-9, 0.0) > 1          # α = K T²/m: any K > 0


def test_undamped_cable_with_b_is_refused_on_the_cable():
    dev = Device(mass=5.4, damping=0.0, sample_time=1e-3, delay=1e-3, cable={**CABLE, "damping": 0.0})
    with pytest.raises(InputError) as err:
        reference_critical_stiffness(dev, 1.0)
    assert err.value.field == "device.cable" and "exact" in err.value.rule
