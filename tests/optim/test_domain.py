"""optim.domain: inside the declared domain every analysis returns finite numbers; outside it, a ValueError
naming the field.  The edges were found by fuzzing the HTTP API (tests/service/test_fuzz_api.py)."""

from __future__ import annotations

import math
import warnings

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from models.device import Device
from optim.analysis import analyse_stability
from optim.domain import DELTA_MAX, DELTA_MIN, check_device_domain


@pytest.mark.parametrize("kwargs,field", [
    ({"mass": 5e-324, "damping": 1.0}, "mass"),           # δ = inf
    ({"mass": 1.0, "damping": 1.0, "sample_time": 5e-324}, "mass"),  # m/T² overflows
    ({"mass": 1.0, "damping": 5e-324}, "damping"),        # δ underflows to 0 with b > 0
    ({"mass": 1e-12, "damping": 1e12, "sample_time": 1.0}, "damping"),  # δ = 1e24
    ({"preset": "lhifam", "human": {"mass": 5e-324}}, "human.mass"),
    ({"preset": "lhifam", "force_sensor": {"time_constant": 1e-300}}, "force_sensor.time_constant"),
    ({"preset": "lhifam", "cable": {"stiffness": 1e-300}}, "cable.stiffness"),
    ({"preset": "lhifam", "cable": {"motor_mass": 1e-40, "body_mass": 5.4}, "mass": None}, "cable.motor_mass"),
])
def test_outside_the_domain_is_a_value_error_naming_the_field(kwargs, field):
    with pytest.raises(ValueError, match=f"^{field}: "):
        check_device_domain(Device(**kwargs))


def test_chapter_devices_are_inside():
    for d in (Device(mass=5.4, damping=3.5), Device(preset="lhifam"), Device(preset="phantom-1.0"),
              Device(mass=1.0, damping=0.0)):
        check_device_domain(d)


_log_delta = st.floats(min_value=math.log10(DELTA_MIN), max_value=math.log10(DELTA_MAX))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(log_delta=_log_delta, delay=st.sampled_from([0.0, 0.5, 3.0, 40.0]),
       log_beta=st.one_of(st.just(None), st.floats(min_value=-6, max_value=3)))
def test_inside_the_domain_every_exact_analysis_is_finite(log_delta, delay, log_beta):
    """Dimensionless device (m = T = 1): only δ, d and β matter (chapter Table 1)."""
    device = Device(mass=1.0, damping=10.0 ** log_delta, sample_time=1.0, delay=delay)
    check_device_domain(device)
    beta = 0.0 if log_beta is None else 10.0 ** log_beta
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # an overflow or 0/0 inside the numerics fails the property
        res = analyse_stability(device, 1.0, beta, "exact")
    assert res.critical_stiffness is None or (math.isfinite(res.critical_stiffness) and res.critical_stiffness >= 0)
    assert math.isfinite(res.linear_estimate)
