"""Robust stiffness design of a rendered wall (optim.robust.rendered_stiffness, issue 30): a 50 Hz first-order velocity
filter over a small box (rigid mass × damping × delay).  The design's K is checked on a dense grid over the box by the
exact rendered analysis and, independently, by the closed loop's eigenvalues with the filter's states; its verify
(optim.verification_robust) closes the loop with the filter at the corners, the worst device and the interior search's
worst; bad combinations are refused naming their field."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from models.device import Device
from models.velocity_filter import LowPass, rendering
from optim.errors import InputError
from optim.robust.box import STIFFNESS_PATHS, UncertaintyBox
from optim.robust.rendered_stiffness import robust_rendered_stiffness
from optim.stability.closed_loop import radius_excess, sampled_plant
from optim.stability.closed_loop_rendered import rendered_closed_loop
from optim.stability.margins import critical_stiffness
from optim.stability.rendered import rendered_critical_stiffness
from optim.stiffness import StiffnessRequirements
from optim.stiffness.design import design_stiffness
from optim.stiffness.rendered_design import design_rendered_stiffness
from optim.stiffness.requirements import CutoffDesign
from optim.verification_robust import interior_search, verify_robust_stiffness

DEV = Device(mass=5.4, damping=3.5, sample_time=0.001, delay=0.0005)
LP50 = LowPass(kind="low_pass", cutoff_hz=50, order=1)
RANGES = {"device.mass": (4.5, 6.5), "device.damping": (2.0, 5.0), "device.delay": (0.0002, 0.0008)}
GM = 6.0


@pytest.fixture(scope="module")
def design():
    box = UncertaintyBox.from_ranges(DEV, RANGES)
    d = robust_rendered_stiffness(DEV, StiffnessRequirements(min_gain_margin_db=GM), box, 0.0, LP50)
    assert d.status == "optimal", d.reason
    return box, d


def test_margin_holds_on_a_dense_grid_by_the_exact_analysis_and_by_eigenvalues(design):
    box, d = design
    k, b = d.stiffness, d.damping
    promised = k * 10.0 ** (GM / 20.0)
    axes = [np.linspace(lo, hi, 6) for lo, hi in RANGES.values()]
    margins = []
    for m, bb, td in itertools.product(*axes):
        dev = Device(mass=m, damping=bb, sample_time=0.001, delay=td)
        r = rendering(LP50, 0.0, dev.sample_time)
        kcr = rendered_critical_stiffness(dev, b, r).critical_stiffness
        margins.append(20 * math.log10(kcr / k))
        # independent: the closed loop with the filter's state, stable at K and just below the promised gain
        plant = sampled_plant(dev)
        t = dev.sample_time
        for gain in (k, promised * (1 - 1e-4)):
            ex = radius_excess(rendered_closed_loop(plant, LP50, t, gain * t * t / m, b * t / m, 0.0))
            assert ex.decided_stable, (m, bb, td, gain)
    assert min(margins) >= GM - 1e-6
    # the design is tight: its worst device sits on the margin (the back-off), found by the search
    assert d.gain_margin_db == pytest.approx(GM, abs=1e-5)
    assert min(margins) >= d.gain_margin_db - 1e-6
    # the filter's lag costs stiffness: below today's wall's robust-free nominal design, and below the filtered
    # nominal design (a box is never easier than its nominal device)
    nominal = design_rendered_stiffness(DEV, StiffnessRequirements(min_gain_margin_db=GM), 0.0, LP50)
    assert d.stiffness < nominal.stiffness < design_stiffness(DEV, StiffnessRequirements(min_gain_margin_db=GM)).stiffness
    assert d.rendered is not None and d.rendered.cutoff_hz == 50 and not d.rendered.designed


def test_the_unfiltered_box_is_contradicted_where_the_filtered_one_is_not(design):
    """verify closes the loop with the filter's states: the same (K, B) checked as today's wall (no filter) gives
    other critical gains, and a wall 1 % stiffer than the filtered margin allows is contradicted."""
    box, d = design
    worst = d.worst_case["device"]
    v = verify_robust_stiffness(box, d.stiffness, d.damping, GM, False, worst, None, (LP50, 0.0))
    assert v.verdict == "confirmed", v.reason
    assert "interior search's worst" in v.reason     # ran (it ends on a corner here: K_cr is monotone in this box)
    assert {p.kind for p in v.points} == {"corner"}
    for p in v.points:
        dev = box.device_at(np.array([p.device[q] for q in box.paths]))
        kcr = rendered_critical_stiffness(dev, d.damping, rendering(LP50, 0.0, dev.sample_time)).critical_stiffness
        assert p.critical_gain == pytest.approx(kcr, rel=1e-12)
    plain = verify_robust_stiffness(box, d.stiffness, d.damping, GM, False, worst, None)
    assert [p.critical_gain for p in plain.points] != [p.critical_gain for p in v.points]
    bad = verify_robust_stiffness(box, d.stiffness * 1.01, d.damping, GM, False, worst, None, (LP50, 0.0))
    assert bad.verdict == "contradicted"


@pytest.mark.parametrize("req,field", [
    (StiffnessRequirements(passivity=True), "requirements.passivity"),
    (StiffnessRequirements(velocity_filter=CutoffDesign(kind="low_pass", design=True, order=1, min_cutoff_hz=5,
                                                        max_cutoff_hz=200)), "requirements.velocity_filter.design"),
])
def test_bad_combinations_name_the_field(req, field):
    box = UncertaintyBox.from_ranges(DEV, RANGES)
    spec = req.velocity_filter if req.velocity_filter is not None else LP50
    with pytest.raises(InputError) as exc:
        robust_rendered_stiffness(DEV, req, box, 0.0, spec)
    assert exc.value.field == field


def test_a_sample_time_range_that_puts_the_cutoff_above_nyquist_names_it():
    box = UncertaintyBox.from_ranges(DEV, {"device.sample_time": (0.001, 0.004)})
    with pytest.raises(InputError) as exc:
        robust_rendered_stiffness(DEV, StiffnessRequirements(), box, 0.0, LowPass(kind="low_pass", cutoff_hz=200,
                                                                                   order=1))
    assert exc.value.field == "requirements.uncertainty.device.sample_time" and "cutoff_hz" in exc.value.rule


def test_the_interior_search_closes_the_loop_with_the_filter(design):
    """A gain between the box's smallest filtered K_cr and its smallest unfiltered K_cr: the rendered search finds
    an unstable device, today's wall's search (no filter state) finds none."""
    box, d = design
    worst = box.device_at(np.array([d.worst_case["device"][q] for q in box.paths]))
    kcr_plain = min(critical_stiffness(dv, d.damping).critical_stiffness for dv in box.devices(box.corners()))
    kcr_filt = d.worst_case["critical_stiffness"]
    assert kcr_filt < 0.9 * kcr_plain
    gain = math.sqrt(kcr_filt * kcr_plain)
    relevant = box.relevant(STIFFNESS_PATHS)
    rendered = interior_search(box, relevant, gain, d.damping, render=(LP50, 0.0))
    plain = interior_search(box, relevant, gain, d.damping)
    assert rendered is not None and rendered.unstable and rendered.excess > 0
    assert plain is not None and not plain.unstable and plain.excess < 0
    assert worst.mass == 4.5


def test_a_virtual_mass_box_design_holds_on_the_grid_and_the_closed_loop():
    """M = −1 kg (inertia compensation) with the default velocity: every grid device keeps the margin (the rendered
    analysis) and is stable at K on the closed loop with the virtual mass's states; verify confirms."""
    box = UncertaintyBox.from_ranges(DEV, RANGES)
    d = robust_rendered_stiffness(DEV, StiffnessRequirements(min_gain_margin_db=GM), box, -1.0, None)
    assert d.status == "optimal" and d.rendered.mass == -1.0
    axes = [np.linspace(lo, hi, 4) for lo, hi in RANGES.values()]
    for m, bb, td in itertools.product(*axes):
        dev = Device(mass=m, damping=bb, sample_time=0.001, delay=td)
        kcr = rendered_critical_stiffness(dev, d.damping, rendering(None, -1.0, 0.001)).critical_stiffness
        assert 20 * math.log10(kcr / d.stiffness) >= GM - 1e-6
        t = dev.sample_time
        ex = radius_excess(rendered_closed_loop(sampled_plant(dev), None, t, d.stiffness * t * t / m, d.damping * t / m,
                                                -1.0 / m))
        assert ex.decided_stable
    v = verify_robust_stiffness(box, d.stiffness, d.damping, GM, False, d.worst_case["device"], None, (None, -1.0))
    assert v.verdict == "confirmed", v.reason


def test_the_noise_rule_caps_b_with_the_filters_step_peak():
    """max_force_noise with the 50 Hz filter: B·q·max|s_k| ≤ 0.5 N binds (B = 0.5/(q·(1 − a)/T) = 185.46 N·s/m, the
    figure of docs/virtual_environment.md's worked example), and the margin still holds over the box."""
    from models.velocity_noise import force_step

    box = UncertaintyBox.from_ranges(DEV, {"device.mass": (4.5, 6.5), "device.delay": (0.0002, 0.0008)})
    req = StiffnessRequirements(min_gain_margin_db=GM, quantization=1e-5, max_force_noise=0.5)
    d = robust_rendered_stiffness(DEV, req, box, 0.0, LP50)
    assert d.status == "optimal" and "max_force_noise" in d.active_constraints
    a = math.exp(-2 * math.pi * 50 * 0.001)
    assert d.damping == pytest.approx(0.5 / (1e-5 * (1 - a) / 0.001), rel=1e-9)
    assert force_step(d.damping, 1e-5, rendering(LP50, 0.0, 0.001).velocity, 0.001) <= 0.5 * (1 + 1e-12)
    assert d.gain_margin_db >= GM - 1e-6
