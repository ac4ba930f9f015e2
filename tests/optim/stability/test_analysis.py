"""The accuracy ladder of optim.stability.analysis, passivity with delay, and the boundary."""

from __future__ import annotations

import math

import numpy as np
import pytest

from models.device import Device
from optim.stability.analysis import analyse_stability, linear_error_estimate
from optim.stability.boundary import stability_boundary
from optim.stability.margins import critical_stiffness, max_stable_damping
from optim.stability.passivity import is_passive, max_passive_stiffness, passivity_margin

LHIFAM = Device(mass=5.4, damping=3.5)


def test_rungs_agree_where_they_should():
    exact = analyse_stability(LHIFAM, 3500.0)
    ref = analyse_stability(LHIFAM, 3500.0, method="reference")
    lin = analyse_stability(LHIFAM, 3500.0, method="linear")
    grid = analyse_stability(LHIFAM, 3500.0, method="grid")
    assert exact.method == "exact" and exact.critical_stiffness == pytest.approx(ref.critical_stiffness, rel=1e-12)
    assert lin.critical_stiffness == 7000.0            # b/(T/2), eq. 10
    assert abs(grid.critical_stiffness / exact.critical_stiffness - 1) <= grid.error_estimate * 2
    assert exact.gain_margin_db == pytest.approx(20 * math.log10(exact.critical_stiffness / 3500.0), abs=1e-12)
    assert all(r.elapsed_ms > 0 for r in (exact, ref, lin, grid))


def test_grid_rung_misses_a_crossover_below_its_grid():
    """FIELD-NOTES: tiny damping + long delay puts the crossover near sqrt(b/(m t_d)); a grid starting at
    1e-3/T misses it and answers a value many orders too large.  The exact rung does not."""
    dev = Device(mass=1.0, damping=1e-9 / 1e-3, delay=0.2)
    exact = analyse_stability(dev)
    grid = analyse_stability(dev, method="grid")
    assert exact.crossover_frequency * dev.sample_time < 1e-3
    assert grid.critical_stiffness > 1e3 * exact.critical_stiffness
    # ... and says so: its error estimate is unbounded (∞; null over HTTP), not the 8e-3 of its bracket
    assert grid.error_estimate == math.inf and "unbounded" in grid.error_source


GRID_CASES = [  # (device, B as a fraction of B_max): the accuracy suite's hard and easy corners
    (Device(mass=5.4, damping=3.5, delay=0.2), 0.0),                      # LHifAM rigid, 200 samples
    (Device(mass=1.0, damping=1e-6 / 1e-3, delay=0.02), 0.0),             # δ = 1e-6, d = 20: crossover below grid
    (Device(mass=1.0, damping=1e-9 / 1e-3), 0.0),                         # δ = 1e-9, d = 0: was "error 0"
    (Device(mass=1.0, damping=1e-12 / 1e-3, delay=0.2), 0.0),
    (Device(mass=1.0, damping=1e-6 / 1e-3), 0.0),                         # δ = 1e-6, d = 0: resolved, finite
    (Device(mass=5.4, damping=3.5, delay=0.005), 0.8),                    # curved part of the boundary
    (Device(preset="lhifam", delay=0.001), 0.3),
    (Device(preset="lhifam", delay=0.2), 0.0),
    (Device(preset="lhifam", sample_time=1e-5, delay=1e-4), 0.0),         # δ = 6.5e-6, fast sampling
    (Device(preset="phantom-1.0", delay=0.0017), 0.0),
]


@pytest.mark.parametrize("device,fraction", GRID_CASES)
def test_grid_error_estimate_is_honest(device, fraction):
    """True error of the grid rung (against the exact rung, itself held to the 40-digit reference elsewhere)
    ≤ 2 × its estimate; an answer the grid cannot vouch for has an unbounded estimate, never a small one."""
    b = fraction * max_stable_damping(device)
    exact = analyse_stability(device, None, b).critical_stiffness
    grid = analyse_stability(device, None, b, method="grid")
    err = abs(grid.critical_stiffness / exact - 1)
    assert err <= 2 * grid.error_estimate
    if err > 0.01:
        assert grid.error_estimate == math.inf


@pytest.mark.parametrize("delta", [1e-5, 1e-3])
@pytest.mark.parametrize("beta", [0.0, 1e-3, 1e-2, 0.1])
@pytest.mark.parametrize("d", [0, 0.5, 1, 2, 5, 20])
def test_linear_error_estimate_is_honest(delta, beta, d):
    """The true error of eq. 10 never exceeds the reported estimate by more than 2×."""
    dev = Device(mass=1.0, damping=delta / 1e-3, delay=d * 1e-3)
    b = beta * dev.damping_scale
    k = critical_stiffness(dev, b).critical_stiffness
    if k == 0.0:
        pytest.skip("B above B_max: the linear rung is meaningless there (the exact rung says why)")
    lin = analyse_stability(dev, damping=b, method="linear")
    true = abs(lin.critical_stiffness / k - 1)
    assert true <= 2 * linear_error_estimate(dev, b)


def test_cable_answers_report_mode_and_Q():
    res = analyse_stability(Device(preset="lhifam"))
    assert res.mode_matters is True                     # 78.9 dB vs 76.9 dB (Table 3)
    assert res.rigid_critical_stiffness == pytest.approx(critical_stiffness(LHIFAM).critical_stiffness, rel=1e-15)
    assert 20 * math.log10(res.q_criterion) == pytest.approx(78.16, abs=0.5)


# --- passivity ------------------------------------------------------------------------------

@pytest.mark.parametrize("k, b_virtual", [(1000.0, 0.0), (3000.0, 1.0), (6000.0, 0.4)])
def test_passivity_is_eq3_without_delay(k, b_virtual):
    check = passivity_margin(LHIFAM, k, b_virtual)
    assert check.required_damping == pytest.approx(k * LHIFAM.sample_time / 2 + b_virtual, rel=1e-12)
    assert max_passive_stiffness(LHIFAM, b_virtual) == pytest.approx((3.5 - b_virtual) / 5e-4, rel=1e-9)


@pytest.mark.parametrize("d", [1, 2, 5])
def test_passivity_with_delay_and_no_virtual_damping_is_b_over_T2_plus_td(d):
    dev = Device(mass=5.4, damping=3.5, delay=d * 1e-3)
    assert max_passive_stiffness(dev, 0.0) == pytest.approx(3.5 / (5e-4 + d * 1e-3), rel=1e-9)


@pytest.mark.parametrize("d", [1, 3])
@pytest.mark.parametrize("b_virtual", [0.5, 2.0])
def test_passivity_with_delay_against_dense_scan(d, b_virtual):
    dev = Device(mass=5.4, damping=3.5, delay=d * 1e-3)
    theta = np.linspace(1e-9, math.pi, 2_000_001)
    kern = np.sin((d + 0.5) * theta) / np.sin(theta / 2)
    cosv = np.cos((d + 1) * theta)
    k = max_passive_stiffness(dev, b_virtual)
    assert k > 0
    worst = np.max(k * 5e-4 * kern - b_virtual * cosv)
    assert worst == pytest.approx(3.5, rel=1e-6)           # K_max makes the bound tight
    assert is_passive(dev, 0.999 * k, b_virtual) and not is_passive(dev, 1.001 * k, b_virtual)


def test_fractional_delay_passivity_is_conservative_and_says_so():
    dev = Device(mass=5.4, damping=3.5, delay=1.3e-3)
    check = passivity_margin(dev, 1000.0, 0.0)
    assert check.conservative and check.delay_samples_used == 2


def test_passivity_lhifam_one_sample_6db_differs_from_eq3():
    """FIELD-NOTES: with one sample of delay, eq. 3 and the delayed form differ (eq. 3 is optimistic)."""
    dev = Device(mass=5.4, damping=3.5, delay=1e-3)
    assert max_passive_stiffness(dev, 0.0) < (3.5 - 0.0) / 5e-4


# --- boundary -------------------------------------------------------------------------------

def test_boundary_is_the_exact_curve_and_its_optimum_is_a_maximum():
    dev = Device(mass=5.4, damping=3.5, delay=0.005)
    b = stability_boundary(dev, points=30)
    for p in b.points[::7]:
        assert p.critical_stiffness == critical_stiffness(dev, p.damping).critical_stiffness
    k_opt = b.optimum.critical_stiffness
    assert k_opt >= max(p.critical_stiffness for p in b.points)
    for s in (0.99, 1.01):
        assert critical_stiffness(dev, b.optimum.damping * s).critical_stiffness <= k_opt * (1 + 1e-9)
    assert b.max_stable_damping == pytest.approx(max_stable_damping(dev), rel=1e-15)
    # the optimum lies in the curved part (Fig. 9): eq. 10 is far off there
    assert b.optimum.linear_estimate > 1.5 * k_opt


@pytest.mark.parametrize("method", ["linear", "grid", "exact", "reference", "Exact", "", None, 3])
@pytest.mark.parametrize("grid_points", [10, 1000, 1_000_000, 9, 1_000_001, 1000.0, 1000.5, "1000", True, None, -5])
def test_check_rung_fast_path_keeps_the_rules_verdict(method, grid_points):
    """check_rung's shortcut for plain valid values answers exactly as its two validators do, everywhere."""
    from pydantic import ValidationError

    from optim.errors import InputError
    from optim.stability.analysis import _RUNG_RULES, check_rung

    def by_rules() -> str | None:
        for name, rule in _RUNG_RULES:
            try:
                rule.validate_python(method if name == "method" else grid_points)
            except ValidationError:
                return name
        return None

    try:
        check_rung(method, grid_points)
        got = None
    except InputError as exc:
        got = exc.field
    assert got == by_rules()


def test_approximate_rungs_label_the_wall_only_outside_their_estimate():
    """Issue 34: a grid or linear K_cr labels a wall stable or unstable only where its own error estimate keeps K on
    one side; past B_max (unbounded grid estimate) it says nothing, where it used to say "stable"."""
    from optim.stability.analysis import _label_within_estimate
    from optim.stability.margins import max_stable_damping
    assert _label_within_estimate(900.0, 1000.0, 0.05) and not _label_within_estimate(990.0, 1000.0, 0.05)
    assert not _label_within_estimate(900.0, 1000.0, math.inf) and not _label_within_estimate(1.0, math.inf, 0.0)
    dev = Device(mass=5.4, damping=3.5, delay=0.001)
    b = 1.01 * max_stable_damping(dev)
    exact = analyse_stability(dev, 100.0, b, "exact")
    grid = analyse_stability(dev, 100.0, b, "grid")
    assert exact.stable is False or exact.stable is None
    assert grid.stable is None or grid.stable == exact.stable
    for method in ("linear", "grid"):
        res = analyse_stability(dev, 1000.0, 0.0, method)
        k, e = res.critical_stiffness, res.error_estimate
        if res.stable is not None:
            assert e is not None and abs(1000.0 / k - 1) > e and res.stable == (1000.0 < k)
