"""Stiffness and inertia designs on every rung (optim/design_ladder.py) against the exact design and closed forms."""

from __future__ import annotations

import math

import pytest

from models.device import Device
from optim.design_ladder import design_inertia_on_rung, design_stiffness_on_rung
from optim.stability.margins import critical_stiffness
from optim.stability.passivity import passivity_margin
from optim.stiffness import StiffnessRequirements
from optim.transparency.inertia import InertiaRequirements
from tests.feedforward_reference import HUMAN_EQ30, LHIFAM_CABLE, LHIFAM_RIGID, SENSOR_EQ31

RIGID = Device(**LHIFAM_RIGID)
CABLE_D1 = Device(**LHIFAM_CABLE, delay=1e-3)
FF_CABLE = Device(**LHIFAM_CABLE, human=HUMAN_EQ30, force_sensor=SENSOR_EQ31)


def test_linear_stiffness_without_limits_is_infeasible_not_invented():
    d, info = design_stiffness_on_rung(RIGID, StiffnessRequirements(), "linear")
    assert d.status == "infeasible" and "unbounded" in d.reason
    assert d.damping is None and d.stiffness is None and info.exact_check is None


def test_linear_stiffness_is_eq10_at_the_damping_limit_and_reports_the_exact_margin():
    """Closed form: B = max_damping, K = g·(b + B)/(T/2); the exact margin of that design is 5.97 dB
    (eq. 10 overestimates K_cr by 0.36 % here), so the design is flagged UNSAFE for 6 dB."""
    req = StiffnessRequirements(max_damping=20.0)
    d, info = design_stiffness_on_rung(RIGID, req, "linear")
    assert d.damping == 20.0
    assert d.stiffness == pytest.approx(req.gain_factor * (3.5 + 20.0) / 0.0005, rel=1e-14)
    exact = critical_stiffness(RIGID, 20.0).critical_stiffness
    chk = info.exact_check
    assert chk.critical_value == pytest.approx(exact, rel=1e-15)
    assert chk.gain_margin_db == pytest.approx(20 * math.log10(exact / d.stiffness), rel=1e-12)
    assert chk.gain_margin_db < 6.0 and not chk.meets_min_gain_margin and chk.statement.startswith("UNSAFE")
    # the rung's error estimate covers eq. 10's true error at that B (within 2x)
    assert abs(d.critical_stiffness / exact - 1) <= 2 * info.error_estimate


def test_linear_stiffness_with_passivity_closed_form():
    """d = 0: K_stab = g(b+B)/(T/2) meets K_pass = (b−B)/(T/2) at B = b(1−g)/(1+g), K = 2gb/((1+g)T/2);
    at d = 0 the sufficient condition is eq. 3 itself, so the design sits exactly on the passivity boundary:
    the exact delayed test (optim.stability.passivity) needs exactly the device's damping b there."""
    req = StiffnessRequirements(max_damping=20.0, passivity=True)
    d, info = design_stiffness_on_rung(RIGID, req, "linear")
    g, b = req.gain_factor, 3.5
    assert d.damping == pytest.approx(b * (1 - g) / (1 + g), rel=1e-12)
    assert d.stiffness == pytest.approx(2 * g * b / ((1 + g) * 0.0005), rel=1e-12)
    need = passivity_margin(RIGID, d.stiffness, d.damping).required_damping
    assert need == pytest.approx(b, rel=1e-9)
    assert info.exact_check.passive is not None


def test_grid_and_reference_stiffness_against_exact():
    req = StiffnessRequirements(max_damping=20.0)
    ex, _ = design_stiffness_on_rung(CABLE_D1, req, "exact")
    gr, gi = design_stiffness_on_rung(CABLE_D1, req, "grid", grid_points=2000)
    assert gr.stiffness == pytest.approx(ex.stiffness, rel=1e-2)          # grid K_cr error ~1e-3 at 2000 points
    assert gi.exact_check is not None and abs(gi.exact_check.gain_margin_db - 6.0) < 0.1
    ex, _ = design_stiffness_on_rung(RIGID, req, "exact")
    ref, ri = design_stiffness_on_rung(RIGID, req, "reference")      # the rigid reference is the cheap one
    assert (ref.stiffness, ref.damping) == (ex.stiffness, ex.damping)
    assert ref.critical_stiffness == pytest.approx(ex.critical_stiffness, rel=1e-12)
    assert ri.error_estimate <= 1e-12 and ri.method == "reference"


def test_linear_inertia_is_eq33_and_flags_the_unsafe_cable_design():
    """Eq. 33 ignores the cable mode: K_f = (1 + m/m_h)/2 at the band's top (ω_n/2π ≈ 84 Hz) has an exact
    margin of about 3 dB on the LHifAM cable model, and the answer says so."""
    req = InertiaRequirements()
    d, info = design_inertia_on_rung(FF_CABLE, req, "linear")
    rho = 10 ** (6 / 20)
    assert d.force_gain == pytest.approx((1 + 5.4 / 2) / rho, rel=1e-14)
    assert d.filter_cutoff_hz == pytest.approx(d.cutoff_band_hz[1], rel=1e-15)
    assert not info.exact_check.meets_min_gain_margin and info.exact_check.gain_margin_db < 6.0
    ex, _ = design_inertia_on_rung(FF_CABLE, req, "exact")
    assert ex.force_gain > d.force_gain  # eq. 33 is not conservative either way: only the check tells


@pytest.mark.slow
def test_grid_and_reference_inertia_against_exact():
    req = InertiaRequirements(target_apparent_mass=0.9)
    ex, _ = design_inertia_on_rung(FF_CABLE, req, "exact")
    gr, gi = design_inertia_on_rung(FF_CABLE, req, "grid")
    assert gr.force_gain == ex.force_gain == pytest.approx(5.0, rel=1e-12)
    assert gr.filter_cutoff_hz == pytest.approx(ex.filter_cutoff_hz, rel=0.01)   # 201 cutoffs over the band
    assert gi.exact_check.gain_margin_db == pytest.approx(6.0, abs=0.05)
    ref, ri = design_inertia_on_rung(FF_CABLE, req, "reference")
    assert ref.critical_force_gain == pytest.approx(ex.critical_force_gain, rel=1e-12)
    assert ri.error_estimate <= 1e-12


def test_bad_method_names_the_field():
    with pytest.raises(ValueError, match="^method"):
        design_stiffness_on_rung(RIGID, None, "closed-form")
    with pytest.raises(ValueError, match="^grid_points"):
        design_inertia_on_rung(FF_CABLE, None, "grid", grid_points=3)
