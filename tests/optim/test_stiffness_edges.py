"""Stiffness designs at the edges issue 17 found: long delays, zero damping, the input limits, labels at the limit.

Every design is re-checked by the project's own analysis (optim.stability.analysis, exact rung) at its (K, B).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from models.device import Device
from optim.stability.analysis import analyse_stability
from optim.stability.margins import critical_stiffness
from optim.stability.passivity import passivity_margin
from optim.stiffness import StiffnessRequirements, design_stiffness
from optim.stiffness.requirements import DESIGN_BACK_OFF
from tests.optim.stiffness_scan import scan_best

# the device: rigid m = 5.4 kg, b = 3.5 N·s/m, T = 1 ms
_SWEEP = sorted({1055, 1056, *np.unique(np.geomspace(200, 10_000, 58).round().astype(int)).tolist()})


def _rigid(delay_samples: float) -> Device:
    return Device(mass=5.4, damping=3.5, sample_time=1e-3, delay=delay_samples * 1e-3)


def _agrees(device: Device, design, req: StiffnessRequirements) -> None:
    assert design.status == "optimal", (device, design.reason)
    a = analyse_stability(device, design.stiffness, design.damping)
    assert a.stable is True
    assert a.critical_stiffness == design.critical_stiffness
    assert a.gain_margin_db >= req.min_gain_margin_db
    if req.passivity:
        assert a.passive is True


@pytest.mark.slow
def test_delay_sweep_200_to_10000_samples_is_never_infeasible():
    """Issue 17: 18 of 301 delays between 200 and 1,700 samples (1,055 the first) and several above 5,000 answered
    "no positive stiffness meets the gain margin for any B" though K_cr(0)/2 meets 6 dB.  Cause: the coarse
    profile read a curve segment joining α = −5,957 to α = +69 near θ = π (β_c swings ~d/(π − θ)² there) as a
    crossover of K_cr = 0 at every β it spans.  60 delays spread over 200–10,000 samples, 1,055 included."""
    assert len(_SWEEP) >= 60 and 1055 in _SWEEP and _SWEEP[-1] == 10_000
    req = StiffnessRequirements(min_gain_margin_db=6.0)
    for d in _SWEEP:
        dev = _rigid(d)
        design = design_stiffness(dev, req)
        _agrees(dev, design, req)
        # never below the B = 0 design the issue names: K_cr(0)/2 meets 6 dB
        assert design.stiffness >= 0.5 * critical_stiffness(dev, 0.0).critical_stiffness * (1 - 1e-6), d


def test_delay_1055_matches_the_dense_scan():
    dev, req = _rigid(1055), StiffnessRequirements(min_gain_margin_db=6.0)
    design = design_stiffness(dev, req)
    _agrees(dev, design, req)
    best, _ = scan_best(dev, req)
    assert design.stiffness == pytest.approx(best, rel=1e-5)


@pytest.mark.parametrize("delay", [0.0, 3e-3, 2.5e-3])
def test_zero_physical_damping_is_designed(delay):
    """b = 0: virtual damping B stabilises the wall (K_cr(0) = 0, K_cr(B) > 0 for 0 < B < B_max)."""
    dev = Device(mass=5.4, damping=0.0, sample_time=1e-3, delay=delay)
    req = StiffnessRequirements(min_gain_margin_db=6.0)
    design = design_stiffness(dev, req)
    _agrees(dev, design, req)
    assert design.damping > 0
    best, _ = scan_best(dev, req)
    assert design.stiffness == pytest.approx(best, rel=1e-5)


def test_zero_physical_damping_with_passivity_is_infeasible_with_the_reason():
    dev = Device(mass=5.4, damping=0.0, sample_time=1e-3, delay=1e-3)
    design = design_stiffness(dev, StiffnessRequirements(passivity=True))
    assert design.status == "infeasible" and "passivity is impossible" in design.reason and "b = 0" in design.reason


@pytest.mark.slow
def test_undamped_cable_is_designed_and_analysed():
    """All six dampings 0 (the LHifAM's cable): the design exists (B stabilises it) and its analysis agrees."""
    dev = Device.model_validate({"preset": "lhifam", "cable": {"motor_damping": 0, "body_damping": 0, "damping": 0}})
    assert critical_stiffness(dev, 0.5).critical_stiffness == pytest.approx(861.5237, rel=1e-6)
    req = StiffnessRequirements(min_gain_margin_db=6.0)
    design = design_stiffness(dev, req)
    _agrees(dev, design, req)
    best, _ = scan_best(dev, req)
    assert design.stiffness >= best * (1 - 1e-5)


def test_undamped_cable_analysis_under_the_service_errstate():
    """The HTTP path runs the analysis under np.errstate(invalid="raise"); a scan sample exactly on the undamped
    pole divided by 0 there ("invalid value encountered in matmul", a 422).  1/G = 0 on the pole."""
    dev = Device.model_validate({"preset": "lhifam", "cable": {"motor_damping": 0, "body_damping": 0, "damping": 0}})
    res = analyse_stability(dev, 100.0, 0.5)
    assert res.critical_stiffness == pytest.approx(861.5237197778189, rel=1e-9)
    with np.errstate(all="raise"):
        from models.plants import stiffness_loop_plant
        plant = stiffness_loop_plant(dev)
        assert np.all(plant.inverse_response(np.array(plant.pole_angles())) == 0.0)


def test_zero_margin_design_is_strictly_stable():
    """min_gain_margin_db = 0 returned K = K_cr exactly, which the analysis calls unstable; now K sits
    DESIGN_BACK_OFF below it."""
    dev = Device(mass=5.4, damping=3.5, sample_time=1e-3)
    req = StiffnessRequirements(min_gain_margin_db=0.0)
    design = design_stiffness(dev, req)
    _agrees(dev, design, req)
    assert design.back_off == DESIGN_BACK_OFF
    assert design.stiffness == pytest.approx(design.critical_stiffness * (1 - DESIGN_BACK_OFF), rel=1e-15)
    assert design.gain_margin_db > 0 and "min_gain_margin_db" in design.active_constraints


@pytest.mark.parametrize("delay_samples", [0, 1, 2.5, 4])
@pytest.mark.parametrize("preset", ["lhifam", None])
def test_passivity_designs_are_analysed_passive(delay_samples, preset):
    """7 of 16 passivity designs with passivity active were analysed passive: false (b equal to the required
    damping to 1 ulp); with the back-off the analysis agrees."""
    dev = (Device(preset="lhifam", delay=delay_samples * 1e-3) if preset else
           Device(mass=1.2, damping=0.8, sample_time=1e-3, delay=delay_samples * 1e-3))
    req = StiffnessRequirements(min_gain_margin_db=3.0, passivity=True)
    design = design_stiffness(dev, req)
    _agrees(dev, design, req)
    assert passivity_margin(dev, design.stiffness, design.damping).required_damping < dev.damping


@pytest.mark.slow
def test_design_at_the_10000_sample_limit_gives_no_sensitivity_with_the_reason():
    dev = _rigid(10_000)
    design = design_stiffness(dev)
    _agrees(dev, design, StiffnessRequirements())
    params = {s.parameter for s in design.sensitivities}
    assert params == {"damping", "mass"}
    assert "no delay sensitivity" in design.sensitivity_note and "no sample_time sensitivity" in design.sensitivity_note
    assert "pydantic" not in design.sensitivity_note


def test_design_at_the_sample_time_limit_steps_backwards():
    dev = Device(mass=5.4, damping=3.5, sample_time=1.0)
    design = design_stiffness(dev)
    _agrees(dev, design, StiffnessRequirements())
    sens = {s.parameter: s.derivative for s in design.sensitivities}
    assert set(sens) == {"damping", "delay", "sample_time", "mass"}
    # the backward step's derivative against a re-solved design at T − 1e-4 s (finite difference)
    lower = design_stiffness(Device(mass=5.4, damping=3.5, sample_time=1.0 - 1e-4))
    fd = (design.stiffness - lower.stiffness) / 1e-4
    assert sens["sample_time"] == pytest.approx(fd, rel=1e-3)
    assert all(math.isfinite(v) for v in sens.values())


def test_exact_scan_fallback_when_ipopt_fails_everywhere(monkeypatch):
    """If Ipopt fails from every seed, the 1-D problem in B is solved on the exact analysis, and says so."""
    import optim.stiffness.design as design_module
    real = design_module.solve_problem

    def failing(*args, **kwargs):
        sol = real(*args, **kwargs)
        return design_module.ProblemSolution(False, "Maximum_Iterations_Exceeded", 200, sol.a, sol.b, sol.thetas,
                                             sol.lam_p, sol.lam_x, sol.lam_g)
    monkeypatch.setattr(design_module, "solve_problem", failing)
    dev = Device(mass=5.4, damping=3.5, sample_time=1e-3, delay=2e-3)
    for req in (StiffnessRequirements(min_gain_margin_db=6.0), StiffnessRequirements(passivity=True)):
        design = design_stiffness(dev, req)
        _agrees(dev, design, req)
        assert design.solver["name"] == "exact B scan" and "Maximum_Iterations_Exceeded" in design.solver["why"]
        assert design.sensitivities == () and "exact B scan" in design.sensitivity_note
        best, _ = scan_best(dev, req)
        assert design.stiffness == pytest.approx(best, rel=1e-5)
