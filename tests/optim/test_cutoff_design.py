"""The rendered wall's design (issue 30): the noise rules, the NLP's filter, the largest passive K, the fixed-filter
design and the designed cutoff, each against an independent computation."""

from __future__ import annotations

import math
import warnings

import casadi as ca
import numpy as np
import pytest
from scipy import signal

from models.device import Device
from models.velocity_filter import DEFAULT_RENDERING, LowPass, MovingAverage, rendering, velocity_transfer
from models.velocity_noise import noise_gain, step_peak
from optim.design_ladder import design_stiffness_on_rung
from optim.errors import InputError
from optim.stability.passivity import largest_passive_stiffness
from optim.stability.passivity_rendered import rendered_passivity
from optim.stability.passivity_rendered_limit import largest_rendered_passive_stiffness
from optim.stability.rendered import rendered_critical_stiffness
from optim.stiffness.cutoff_problem import casadi_low_pass
from optim.stiffness.rendered_design import FilterContext, best_damping, low_pass_rendering
from optim.stiffness.requirements import CutoffDesign, StiffnessRequirements

LHIFAM = Device(mass=5.4, damping=3.5, sample_time=0.001)


def _summed(vt, n: int = 400_000) -> tuple[float, float]:
    """(max|s_k|·T, sqrt(Σh²)·T) by running the filter (the reference)."""
    x = np.zeros(n)
    x[0] = 1.0
    h = signal.lfilter(np.convolve([1.0, -1.0], vt.r), vt.d, x)
    return float(np.max(np.abs(np.cumsum(h)))), float(math.sqrt(np.sum(h * h)))


@pytest.mark.parametrize("spec", [LowPass(kind="low_pass", cutoff_hz=50, order=1),
                                  LowPass(kind="low_pass", cutoff_hz=50, order=2),
                                  LowPass(kind="low_pass", cutoff_hz=0.05, order=2),
                                  MovingAverage(kind="moving_average", samples=5)])
def test_noise_rules_against_the_filter_run(spec):
    vt = velocity_transfer(spec, 1e-3)
    s, n = _summed(vt)
    assert step_peak(vt, 1e-3) * 1e-3 == pytest.approx(s, rel=1e-9)
    assert noise_gain(vt, 1e-3) * 1e-3 == pytest.approx(n, rel=1e-8)


def test_noise_rules_closed_forms():
    t = 1e-3
    bd = velocity_transfer(None, t)
    assert step_peak(bd, t) == 1 / t and noise_gain(bd, t) == pytest.approx(math.sqrt(2) / t, rel=1e-15)
    a = math.exp(-2 * math.pi * 30 * t)
    vt = velocity_transfer(LowPass(kind="low_pass", cutoff_hz=30, order=1), t)
    assert step_peak(vt, t) == pytest.approx((1 - a) / t, rel=1e-13)
    assert noise_gain(vt, t) == pytest.approx((1 - a) / t * math.sqrt(2 / (1 + a)), rel=1e-12)


@pytest.mark.parametrize("order", [1, 2])
def test_casadi_filter_is_the_model_filter(order):
    # order 2: D(e^{-jθ}) near θ = 0 is 4Ω² out of terms of size 1 (Ω = tan(πν) ~ 3e-4 at ν = 1e-4): both forms lose
    # ~7 digits there (the NLP's form only searches; the exact check uses the model's)
    tol = 1e-12 if order == 1 else 1e-8
    th, nu = ca.SX.sym("t"), ca.SX.sym("n")
    f = ca.Function("f", [th, nu], list(casadi_low_pass(th, nu, order)))
    for n in (1e-4, 0.02, 0.3):
        vt = velocity_transfer(LowPass(kind="low_pass", cutoff_hz=n, order=order), 1.0)
        for t in (1e-6, 0.1, 2.0, 3.0):
            ref = complex(vt.response(np.array([t]))[0])
            got = complex(float(f(t, n)[0]), float(f(t, n)[1]))
            assert abs(got - ref) <= tol * abs(ref)


@pytest.mark.parametrize("delay", [0.0, 0.001, 0.0025])
@pytest.mark.parametrize("b", [0.0, 1.0, 2.5])
def test_largest_passive_stiffness_reduces_to_todays(delay, b):
    dev = Device(mass=5.4, damping=3.5, sample_time=0.001, delay=delay)
    k, _ = largest_rendered_passive_stiffness(dev, b, DEFAULT_RENDERING)
    assert k == pytest.approx(largest_passive_stiffness(dev, b).stiffness, rel=1e-9)


def test_largest_passive_stiffness_of_a_filtered_wall_is_the_passivity_edge():
    dev = Device(mass=5.4, damping=3.5, sample_time=0.001, delay=0.001)
    r = rendering(LowPass(kind="low_pass", cutoff_hz=30, order=2), 0.0, 0.001)
    k, _ = largest_rendered_passive_stiffness(dev, 1.0, r)
    assert rendered_passivity(dev, k * (1 - 1e-8), 1.0, r).passive
    assert not rendered_passivity(dev, k * (1 + 1e-6), 1.0, r).passive


def test_requirements_noise_rules():
    with pytest.raises(ValueError, match="quantization: required when max_force_noise_rms"):
        StiffnessRequirements(max_force_noise_rms=0.1)
    req = StiffnessRequirements(quantization=1e-5, max_force_noise_rms=0.1)
    assert req.damping_caps(1e-3)["max_force_noise_rms"] == pytest.approx(0.1 * math.sqrt(6) * 1e-3 / 1e-5, rel=1e-14)
    with pytest.raises(ValueError, match="max_cutoff_hz: the cutoff range is empty"):
        CutoffDesign(kind="low_pass", design=True, min_cutoff_hz=50, max_cutoff_hz=5)
    for lo, hi, field in ((1, 500, "velocity_filter.max_cutoff_hz"), (600, None, "velocity_filter.min_cutoff_hz")):
        with pytest.raises(InputError) as e:
            CutoffDesign(kind="low_pass", design=True, min_cutoff_hz=lo, max_cutoff_hz=hi).band(1e-3)
        assert e.value.field == field


def test_rendered_design_refuses_approximate_rungs():
    req = StiffnessRequirements(velocity_filter=LowPass(kind="low_pass", cutoff_hz=50))
    with pytest.raises(InputError) as e:
        design_stiffness_on_rung(LHIFAM, req, "grid")
    assert e.value.field == "method"


def test_fixed_filter_design_is_on_its_exact_edge():
    """LHifAM rigid, 50 Hz first order, a 10 µm encoder and a 0.5 N force step: the noise rule and the margin
    bind, and a larger B (the noise cap) or a larger K (the margin) breaks one of them."""
    warnings.filterwarnings("ignore")
    req = StiffnessRequirements(quantization=1e-5, max_force_noise=0.5)
    spec = LowPass(kind="low_pass", cutoff_hz=50, order=1)
    d, rung = design_stiffness_on_rung(LHIFAM, req, velocity_filter=spec)
    assert d.status == "optimal" and rung.exact_check.safe
    assert set(d.active_constraints) == {"min_gain_margin_db", "max_force_noise"}
    assert d.rendered.force_step == pytest.approx(0.5, rel=1e-9) and d.rendered.force_step <= 0.5 * (1 + 1e-12)
    r = rendering(spec, 0.0, 1e-3)
    kcr = rendered_critical_stiffness(LHIFAM, d.damping, r).critical_stiffness
    assert d.stiffness == pytest.approx(kcr / 10 ** (6 / 20), rel=1e-7)
    # the objective rises with B up to the cap: a B below it gives less K
    lower = rendered_critical_stiffness(LHIFAM, 0.9 * d.damping, r).critical_stiffness * req.gain_factor
    assert lower < d.stiffness


@pytest.mark.slow
def test_designed_cutoff_beats_a_scan_over_the_cutoff():
    """The designed cutoff's K against the best fixed-filter design at 5 cutoffs around it (≥ all, to 1e-6)."""
    warnings.filterwarnings("ignore")
    spec = CutoffDesign(kind="low_pass", design=True, order=1, min_cutoff_hz=5, max_cutoff_hz=400)
    req = StiffnessRequirements(quantization=1e-5, max_force_noise_rms=0.05, velocity_filter=spec)
    d, rung = design_stiffness_on_rung(LHIFAM, req)
    assert d.status == "optimal" and rung.exact_check.safe and d.rendered.designed
    assert "max_force_noise_rms" in d.active_constraints
    plain = StiffnessRequirements(quantization=1e-5, max_force_noise_rms=0.05)
    ctx = FilterContext(LHIFAM, plain, 0.0, {}, plain.gain_factor)
    f = d.rendered.cutoff_hz
    for g in f * np.geomspace(0.7, 1.4, 5):
        assert best_damping(ctx, low_pass_rendering(1, float(g), 1e-3, 0.0))[1] <= d.stiffness * (1 + 1e-6)


@pytest.mark.slow
def test_designed_cutoff_with_passivity_meets_all_three():
    """LHifAM rigid, half a sample of delay, passivity and a 2 mN rms noise limit: margin, passivity and the noise
    rule all bind at the designed cutoff, and the exact check agrees."""
    warnings.filterwarnings("ignore")
    dev = Device(mass=5.4, damping=3.5, sample_time=0.001, delay=0.0005)
    spec = CutoffDesign(kind="low_pass", design=True, order=1, min_cutoff_hz=5, max_cutoff_hz=400)
    req = StiffnessRequirements(passivity=True, quantization=1e-5, max_force_noise_rms=0.002, velocity_filter=spec)
    d, rung = design_stiffness_on_rung(dev, req)
    assert d.status == "optimal" and rung.exact_check.safe and rung.exact_check.passive
    assert set(d.active_constraints) == {"min_gain_margin_db", "passivity", "max_force_noise_rms"}
    r = rendering(LowPass(kind="low_pass", cutoff_hz=d.rendered.cutoff_hz, order=1), 0.0, 1e-3)
    assert rendered_passivity(dev, d.stiffness, d.damping, r).passive
