"""The crossover NLP of the inertia design (optim.transparency.inertia_nlp): a plant's own cutoff scale, and plants of
different orders in one problem, checked against the exact analysis (optim.transparency.feedforward) and optim.transparency.inertia."""

from __future__ import annotations

import math

import pytest

from models.device import Device, ForceSensor
from models.feedforward import feedforward_plant
from optim.transparency.feedforward import critical_force_gain_of_plant, resolve_human
from optim.transparency.inertia import InertiaRequirements, design_inertia
from optim.transparency.inertia_nlp import modal_plant, solve_crossover_nlp

LH = Device(preset="lhifam")
LOG_RHO = math.log(10 ** (6 / 20))


def _plant(device: Device):
    return feedforward_plant(device, resolve_human(device)[0])


def _tracked(plant, theta_c: float, index: int = 0) -> list[tuple[int, float]]:
    return [(index, a) for a, _ in critical_force_gain_of_plant(plant, theta_c, 2)[2]]


def test_cutoff_scale_is_the_same_cutoff_in_hz():
    """A device at T₂ = 0.8 ms in an NLP whose cutoff variable is the angle at T_ref = 1 ms (scale T₂/T_ref) finds
    the same highest cutoff in Hz as the NLP in its own angle, and both are optim.transparency.inertia's exact boundary."""
    t2, t_ref = 0.0008, 0.001
    dev = LH.model_copy(update={"sample_time": t2})
    ref = design_inertia(dev, InertiaRequirements(target_apparent_mass=1.5))
    theta_star = 2 * math.pi * ref.filter_cutoff_hz * t2
    plant = _plant(dev)
    modal, err = modal_plant(plant)
    assert err <= 1e-8
    start = 0.9 * theta_star
    tracked = _tracked(plant, start)
    y = math.log(LH.mass / 1.5 - 1)
    own = solve_crossover_nlp([modal], tracked, 2, LOG_RHO, start, (0.8 * theta_star, 1.2 * theta_star), y,
                              "max_cutoff", y)
    s = t2 / t_ref
    scaled = solve_crossover_nlp([modal], tracked, 2, LOG_RHO, start / s, (0.8 * theta_star / s, 1.2 * theta_star / s),
                                 y, "max_cutoff", y, cutoff_scales=[s])
    assert own.success and scaled.success
    assert scaled.cutoff_angle * s == pytest.approx(own.cutoff_angle, rel=1e-9)
    assert own.cutoff_angle == pytest.approx(theta_star, rel=1e-7)


def test_plants_of_different_orders_share_one_problem():
    """A device with a force-sensor filter and one without (T_f = 0: one state fewer, as at a corner of a box over
    device.force_sensor.time_constant) in one NLP, the cutoff fixed: the gain found is the smaller exact K_f,cr of
    the two (the padded modes add nothing)."""
    plants = [_plant(LH), _plant(LH.model_copy(update={"force_sensor": ForceSensor(time_constant=0.0)}))]
    modal = [modal_plant(p) for p in plants]
    assert max(e for _, e in modal) <= 1e-8 and len(modal[0][0].poles) == len(modal[1][0].poles) + 1
    theta_c = 2 * math.pi * 20.0 * LH.sample_time
    k_exact = [critical_force_gain_of_plant(p, theta_c, 2)[0] for p in plants]
    tracked = _tracked(plants[0], theta_c, 0) + _tracked(plants[1], theta_c, 1)
    res = solve_crossover_nlp([m for m, _ in modal], tracked, 2, LOG_RHO, theta_c, (theta_c, theta_c),
                              math.log(min(k_exact)) - LOG_RHO - 0.1, "max_gain")
    assert res.success
    assert math.exp(res.log_gain + LOG_RHO) == pytest.approx(min(k_exact), rel=1e-8)
    assert max(k_exact) > 1.01 * min(k_exact)           # the two differ: the smaller one is found, not either


@pytest.mark.parametrize("update", [{"sample_time": 3.3e-5}, {"sample_time": 1e-4}, {"sample_time": 0.03},
                                    {"cable": None}], ids=["T=33us", "T=100us", "T=30ms", "rigid"])
def test_modal_form_matches_the_exact_response(update):
    """The modal G_1 (continuous eigen-decomposition, poles as q = λ − 1) against the exact ZOH response
    (models.discretize, resolvent of E = Φ − I) on a grid denser than modal_plant's own check, down to θ_min."""
    import numpy as np

    plant = _plant(LH.model_copy(update=update))
    modal, err = modal_plant(plant)
    theta = np.concatenate([np.geomspace(max(plant.theta_min, 1e-7), 0.1, 400), np.linspace(0.1, math.pi, 400)])
    exact = plant.response(theta)
    worst = float(np.max(np.abs(modal.response(theta) - exact) / np.abs(exact)))
    assert err <= 1e-11 and worst <= 1e-11
    # the poles are Φ's eigenvalues, as a set, to the accuracy of eig(Φ) itself: ε·cond(V) ≈ 3e-12 at T = 33 µs
    phi = plant.matrices()[0]
    np.testing.assert_allclose(np.sort_complex(modal.poles), np.sort_complex(np.linalg.eigvals(phi)), rtol=0,
                               atol=1e-10)
