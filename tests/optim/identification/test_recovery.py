"""Recovered parameters from the scene simulator's data (tests/optim/identification/cases.py: noise levels
and tolerances), `auto` choosing the true model, and a response and a record of one device agreeing."""

from __future__ import annotations

import pytest

from optim.identification import identify
from tests.optim.identification.cases import (
    DAMPING_RTOL,
    DELAY_ATOL,
    DELAYS,
    FRICTION,
    MASS_RTOL,
    device,
    noisy_response,
    record,
)


def _check_rigid(res, dev):
    p = res.parameters
    assert res.status == "identified" and res.model == "rigid", res.reason
    assert p["mass"].value == pytest.approx(dev.mass, rel=MASS_RTOL)
    assert p["damping"].value == pytest.approx(dev.damping, rel=DAMPING_RTOL)
    assert abs(p["delay"].value - dev.delay) <= DELAY_ATOL


@pytest.mark.slow
@pytest.mark.parametrize("delay", DELAYS)
def test_rigid_recovery(delay):
    dev = device("rigid", delay)
    res = identify(record("rigid", delay), model="rigid")
    _check_rigid(res, dev)
    assert res.fit.residual_whiteness["white"], res.fit.residual_whiteness
    assert res.device["delay"] == res.parameters["delay"].value


@pytest.mark.slow
@pytest.mark.parametrize("delay", (0.0007, 0.0026))
def test_rigid_with_friction(delay):
    """Coulomb friction in the data: with the friction term the tolerances hold; without it the damping is
    biased upward (FIELD-NOTES.md), and the fit says its residual is not white."""
    dev = device("rigid", delay)
    data = record("rigid", delay, FRICTION)
    res = identify(data, model="rigid", friction=True)
    _check_rigid(res, dev)
    assert res.parameters["friction"].value == pytest.approx(FRICTION, rel=0.1)
    bare = identify(data, model="rigid")
    assert bare.parameters["damping"].value > dev.damping * (1 + DAMPING_RTOL)
    # leaving friction out is a misspecified model: flagged, no uncertainty box (issue 34)
    assert bare.status == "identified_with_warnings" and not bare.uncertainty
    assert any(w.startswith("misspecification: the residual is far from white") for w in bare.warnings)


def _check_cable(res, dev):
    p, c = res.parameters, dev.cable
    assert res.status == "identified" and res.model == "cable", res.reason
    for name in ("motor_mass", "body_mass", "stiffness"):
        assert p[f"cable.{name}"].value == pytest.approx(getattr(c, name), rel=MASS_RTOL), name
    total = p["cable.motor_damping"].value + p["cable.body_damping"].value
    assert total == pytest.approx(c.motor_damping + c.body_damping, rel=DAMPING_RTOL)
    assert p["cable.damping"].value == pytest.approx(c.damping, rel=DAMPING_RTOL)
    assert abs(p["delay"].value - dev.delay) <= DELAY_ATOL


@pytest.mark.slow
@pytest.mark.parametrize("delay", (0.0, 0.0013, 0.0025))
def test_cable_recovery_and_auto(delay):
    """The LHifAM cable device (84 Hz mode): `auto` chooses cable, and the parameters hold their tolerances."""
    res = identify(record("cable", delay), model="auto")
    _check_cable(res, device("cable", delay))
    assert "cable mode matters" in res.reason
    assert {c.model for c in res.comparison} == {"rigid", "cable"}
    assert set(res.uncertainty) == {f"device.{n}" for n in res.parameters}


@pytest.mark.slow
@pytest.mark.parametrize("delay", (0.0017,))
def test_auto_chooses_rigid_for_a_rigid_device(delay):
    res = identify(record("rigid", delay), model="auto")
    _check_rigid(res, device("rigid", delay))
    assert "does not matter" in res.reason or "only the rigid fit" in res.reason


@pytest.mark.slow
@pytest.mark.parametrize("kind", ("rigid", "cable"))
def test_response_recovery(kind):
    """A measured response (1 % relative noise, 60 points 1-300 Hz): auto chooses the true model."""
    res = identify(noisy_response(kind, 0.0023), model="auto")
    (_check_rigid if kind == "rigid" else _check_cable)(res, device(kind, 0.0023))


@pytest.mark.slow
@pytest.mark.parametrize("kind", ("rigid", "cable"))
def test_sampled_response_recovery(kind):
    """The loop's own response (force sample to encoder sample, ZOH included) fitted as such; auto chooses."""
    res = identify(noisy_response(kind, 0.0014, kind_of_response="sampled"), model="auto")
    (_check_rigid if kind == "rigid" else _check_cable)(res, device(kind, 0.0014))


@pytest.mark.slow
@pytest.mark.parametrize("kind", ("rigid", "cable"))
def test_response_and_record_agree(kind):
    """The same device measured twice (a sine sweep and a chirp record): every parameter's two intervals
    overlap."""
    a = identify(noisy_response(kind, 0.0012), model=kind)
    b = identify(record(kind, 0.0012), model=kind)
    assert a.status == b.status == "identified"
    for name, pa in a.parameters.items():
        pb = b.parameters[name]
        assert pa.interval[0] <= pb.interval[1] and pb.interval[0] <= pa.interval[1], (name, pa, pb)


def test_known_parameter_is_held():
    res = identify(record("rigid", 0.0007), model="rigid", known={"delay": 0.0007})
    assert res.parameters["delay"].value == 0.0007 and res.parameters["delay"].std_error == 0.0
    assert "device.delay" not in res.uncertainty
    assert res.parameters["mass"].value == pytest.approx(5.4, rel=MASS_RTOL)


@pytest.mark.slow
@pytest.mark.parametrize("delay", (0.0, 0.0013))
def test_cable_with_friction(delay):
    """Coulomb friction on the cable device's motor mass (1 % of the excitation): masses, stiffness and delay
    hold their tolerances, the total damping b_r + b_d its 10 %; the cable damping b_c is biased by up to
    ~12 % (measured: 3-12 % over delays 0-2.5 ms), so it is held to 15 % here (docs/identification.md), and
    the answer is flagged as misspecified (the friction term is an approximation: the residual is far from
    white), with widened intervals and no uncertainty box (issue 34)."""
    dev = device("cable", delay)
    res = identify(record("cable", delay, FRICTION), model="cable", friction=True)
    p, c = res.parameters, dev.cable
    assert res.status == "identified_with_warnings" and not res.uncertainty, res.reason
    for name in ("motor_mass", "body_mass", "stiffness"):
        assert p[f"cable.{name}"].value == pytest.approx(getattr(c, name), rel=MASS_RTOL), name
    total = p["cable.motor_damping"].value + p["cable.body_damping"].value
    assert total == pytest.approx(c.motor_damping + c.body_damping, rel=DAMPING_RTOL)
    assert p["cable.damping"].value == pytest.approx(c.damping, rel=0.15)
    assert abs(p["delay"].value - dev.delay) <= DELAY_ATOL
    assert any(w.startswith("misspecification: ") for w in res.warnings)


@pytest.mark.slow
@pytest.mark.parametrize("kind,delay", (("rigid", 0.0007), ("cable", 0.0023)))
def test_recovery_under_a_weak_pd(kind, delay):
    """The experiment runs under a weak PD wall (K = 200 N/m, B = 5 N·s/m) on the noisy, quantised position: the
    commanded force then depends on the measurement noise, but that noise is white and the plant strictly
    delayed, so output error stays consistent and the tolerances hold; `auto` still chooses the true model."""
    from optim.identification import TimeSeriesData
    from tests.optim.identification.cases import AMPLITUDE, NOISE, QUANTIZATION, N, T
    from tests.optim.identification.synthetic import excitation, simulate_experiment

    u, y = simulate_experiment(device(kind, delay), excitation(N, T, amplitude=AMPLITUDE, seed=2),
                               quantization=QUANTIZATION, noise=NOISE, pd=(200.0, 5.0))
    res = identify(TimeSeriesData(T, u, y), model="auto")
    (_check_rigid if kind == "rigid" else _check_cable)(res, device(kind, delay))
