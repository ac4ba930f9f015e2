"""optim.domain: inside the declared domain every analysis returns finite numbers; outside it, a ValueError
naming the field.  The edges were found by fuzzing the HTTP API (tests/service/test_fuzz_api.py)."""

from __future__ import annotations

import math
import warnings

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from models.device import Device
from optim.domain import DELTA_MAX, DELTA_MIN, check_device_domain
from optim.stability.analysis import analyse_stability


@pytest.mark.parametrize("kwargs,field", [
    ({"mass": 5e-324, "damping": 1.0}, "mass"),           # δ = inf
    # a subnormal T is named itself (issue 29: it was blamed on the mass); past SAMPLE_TIME_MIN only the mass can
    # take m/T² or m/T out of range
    ({"mass": 1.0, "damping": 1.0, "sample_time": 5e-324}, "sample_time"),
    ({"mass": 1.0, "damping": 1.0, "sample_time": 1e-101}, "sample_time"),
    ({"mass": 1e-300, "damping": 0.0, "sample_time": 1e-30}, "mass"),
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


# --- what a request adds to its device: filter cutoffs, grasps, uncertainty boxes (issue 10) ---------------

from models.device import Human  # noqa: E402
from models.filters import ButterworthLowPass  # noqa: E402
from optim.domain import CUTOFF_RATIO_MIN, RATIO_MIN, check_cutoff_domain, check_human_domain, check_human_mass  # noqa: E402
from optim.transparency.feedforward_ladder import analyse_force_feedforward  # noqa: E402

_FF = Device(mass=5.4, damping=3.5, human={"mass": 2, "damping": 2, "stiffness": 10},
             force_sensor={"time_constant": 0.005})


@pytest.mark.parametrize("cutoff_hz", [5e-324, 1e-300, 0.99 * CUTOFF_RATIO_MIN / 0.001])
def test_a_cutoff_below_the_domain_is_refused_naming_the_field(cutoff_hz):
    with pytest.raises(ValueError, match=r"^filter\.cutoff_hz: cutoff_hz·sample_time = .* must be ≥ 1e-09"):
        check_cutoff_domain(cutoff_hz, 0.001, "filter.cutoff_hz")
    check_cutoff_domain(CUTOFF_RATIO_MIN / 0.001, 0.001, "filter.cutoff_hz")


@pytest.mark.slow
@pytest.mark.parametrize("order", [1, 4])
def test_at_the_lowest_cutoff_exact_agrees_with_the_reference(order):
    """The rule's justification: at f_c·T = CUTOFF_RATIO_MIN the exact rung still agrees with the 40-digit
    reference (rtol 1e-9: both are exact to ~1e-12; at 1e-12 the reference's scan misses the crossover)."""
    filt = ButterworthLowPass(order, CUTOFF_RATIO_MIN / 0.001, 0.001)
    exact = analyse_force_feedforward(_FF, filt, method="exact").critical_force_gain
    ref = analyse_force_feedforward(_FF, filt, method="reference").critical_force_gain
    assert math.isfinite(exact) and exact == pytest.approx(ref, rel=1e-9)


def test_first_order_cutoff_scaling_law_holds_down_to_the_limit():
    """A first-order D(z) far below the loop's crossover scales K_f,cr as 1/θ_c (|D| ≈ θ_c/θ there): an
    independent check that the exact rung is still resolving the filter at the domain's edge (rtol 1e-3:
    the law is asymptotic; its correction is ≈ 1 % at f_c·T = 1e-6, proportional to f_c, so ≈ 1e-4 here)."""
    k = [analyse_force_feedforward(_FF, ButterworthLowPass(1, r / 0.001, 0.001), method="exact").critical_force_gain
         for r in (10 * CUTOFF_RATIO_MIN, CUTOFF_RATIO_MIN)]
    assert k[1] / k[0] == pytest.approx(10.0, rel=1e-3)


@pytest.mark.serial   # a wall-clock budget: alone under pytest-xdist (tests/conftest.py)
def test_the_linear_rung_is_quick_at_the_lowest_cutoff():
    """It marched in steps of 0.3·θ_c above 0.05 rad: ~1/θ_c steps, a hang for a tiny cutoff (fuzz finding)."""
    import time

    t0 = time.perf_counter()
    res = analyse_force_feedforward(_FF, ButterworthLowPass(2, CUTOFF_RATIO_MIN / 0.001, 0.001), method="linear")
    assert time.perf_counter() - t0 < 2.0 and math.isfinite(res.critical_force_gain)


def test_grasps_beside_the_device_are_held_to_the_device_ratios():
    with pytest.raises(ValueError, match=r"^requirements\.humans\.0\.mass: human mass/mass"):
        check_human_domain(Human(mass=5e-324, damping=0, stiffness=0), _FF, "requirements.humans.0")
    with pytest.raises(ValueError, match=r"^requirements\.humans\.1\.stiffness: "):
        check_human_domain(Human(mass=1, damping=0, stiffness=1e-300), _FF, "requirements.humans.1")
    with pytest.raises(ValueError, match=r"^requirements\.human_mass_range\.min: "):
        check_human_mass(1e-40, _FF, "requirements.human_mass_range.min")
    check_human_domain(Human(mass=5.4 * RATIO_MIN * 1.01, damping=0, stiffness=0), _FF, "requirements.humans.0")


def test_uncertainty_box_ends_must_stay_in_the_domain():
    from optim.robust.box import UncertaintyBox

    with pytest.raises(ValueError, match=r"^requirements\.uncertainty\.device\.human\.mass: 1e-300 leaves"):
        UncertaintyBox.from_ranges(_FF, {"device.human.mass": (1e-300, 2.0)})
    UncertaintyBox.from_ranges(_FF, {"device.human.mass": (0.5, 4.0)})
