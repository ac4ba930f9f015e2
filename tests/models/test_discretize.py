"""Exact ZOH discretisation: series, closed form vs state space vs mpmath."""

from __future__ import annotations

import math

import mpmath as mp
import numpy as np
import pytest

from models.device import Device
from models.discretize import RigidZOH, StateSpaceZOH, phi1, phi2, rigid_coefficients, split_delay, split_delay_array
from models.plants import cable_tfs, stiffness_loop_plant


@pytest.mark.parametrize("x", [0.0, 1e-14, 1e-9, 1e-6, 1e-3, 0.3, 0.999, 1.0, 1.5, 20.0])
def test_phi_functions_against_mpmath(x):
    with mp.workdps(50):
        X = mp.mpf(x)
        f1 = mp.mpf(1) if x == 0 else -mp.expm1(-X) / X
        f2 = mp.mpf(0.5) if x == 0 else (X + mp.expm1(-X)) / X**2
    assert phi1(x) == pytest.approx(float(f1), rel=4e-16)
    assert phi2(x) == pytest.approx(float(f2), rel=4e-16)


def test_split_delay_snaps_binary_noise_only():
    assert split_delay(0.003 / 0.001) == (3, 0.0)
    d, f = split_delay(3 - 1e-9)
    assert d == 2 and f == pytest.approx(1 - 1e-9, rel=1e-15)
    assert split_delay(2.25) == (2, 0.25)


def _rigid_mp(delta, d, f, theta, dps=60):
    """Modified z-transform of 1/(s²(s+δ)) in mpmath (an independent derivation)."""
    with mp.workdps(dps):
        a, f, th = mp.mpf(delta), mp.mpf(f), mp.mpf(theta)
        # θ = π is the Nyquist point itself (z = −1 exactly, as RigidZOH.inverse_at_nyquist takes it), not the
        # double nearest π, whose sin ≈ 1.2e-16 would put z + 1 off the real axis
        z = mp.mpf(-1) if theta == math.pi else mp.expj(th)
        m = 1 - f
        e = mp.exp(-a)
        if f == 0:
            zs = -z / (z - 1) / a**2 + z / (z - 1) ** 2 / a + z / (z - e) / a**2
            g = (1 - 1 / z) * z ** (-d) * zs
        else:
            zs = z / (z - 1) * (m / a - 1 / a**2) + z / (z - 1) ** 2 / a + mp.exp(-a * m) / a**2 * z / (z - e)
            g = (1 - 1 / z) * z ** (-d - 1) * zs
        return complex(g)


@pytest.mark.parametrize("delta", [1e-12, 1e-6, 1e-3, 0.5, 3.0])
@pytest.mark.parametrize("d, f", [(0, 0.0), (1, 0.0), (2, 0.3), (0, 1e-6), (5, 1 - 1e-6)])
def test_rigid_closed_form_against_mpmath(delta, d, f):
    """1e-12 relative, except near z = -1, where G has a near-zero when f(1-f) and δ are small.

    There N(-1) ≈ 2f(1-f) - δ/6 is a difference of O(1) terms, so its relative condition is
    1/(f(1-f) + δ/6) (f = 0 has its own series and stays exact).  The Nyquist crossover inherits this,
    but its stiffness is then ~1/(f + δ) times larger than the low crossover and never sets K_cr.
    """
    plant = RigidZOH(delta, d, f)
    cond = 1.0 if f == 0.0 else max(1.0, 1.0 / (f * (1 - f) + delta / 6))
    theta = np.array([1e-7, 1e-4, 0.03, 1.0, 2.5, math.pi])
    got = plant.response(theta)
    for th, g in zip(theta, got):
        ref = _rigid_mp(delta, d, f, th, dps=60 + int(2 * -math.log10(delta)))
        tol = 1e-12 * (cond if th > 3.0 else 1.0)
        assert abs(g - ref) <= tol * abs(ref)


def test_rigid_closed_form_equals_generic_state_space():
    for delta, d, f in ((1e-3, 0, 0.0), (0.02, 3, 0.4)):
        a = np.array([[0.0, 1.0], [0.0, -delta]])
        ss = StateSpaceZOH(a=a, b=np.array([0.0, 1.0]), c=np.array([1.0, 0.0]), d=d, f=f)
        theta = np.linspace(0.01, math.pi, 50)
        np.testing.assert_allclose(ss.response(theta), RigidZOH(delta, d, f).response(theta), rtol=1e-10)


def test_cable_response_tends_to_continuous_at_low_frequency():
    """Below the mode, Z[H G_r e^{-t_d s}](e^{jωT}) ≈ G_r(jω)·e^{-jω(T/2 + t_d)} (ZOH ≈ half-sample delay)."""
    dev = Device(preset="lhifam", delay=0.002)
    plant = stiffness_loop_plant(dev)
    w = np.array([1.0, 5.0, 20.0])
    got = plant.response(w * dev.sample_time) / dev.stiffness_scale
    approx = cable_tfs(dev)["G_r"](1j * w) * np.exp(-1j * w * (dev.sample_time / 2 + dev.delay))
    # the approximation error is O((ωT)²)
    rel = np.abs(got / approx - 1)
    assert np.all(rel <= (w * dev.sample_time) ** 2 + 1e-9), rel


def test_cable_matrices_keep_the_integrator_exactly_at_one():
    plant = stiffness_loop_plant(Device(preset="lhifam"))
    phi, g0, g1, c = plant.matrices()
    assert phi[0, 0] == 1.0 and np.all(phi[1:, 0] == 0.0)


def test_array_forms_equal_the_scalar_ones():
    """rigid_coefficients and split_delay_array (the batch path's) against RigidZOH and split_delay, to 4 ulp."""
    rng = np.random.default_rng(3)
    delta = np.concatenate([10 ** rng.uniform(-12, 1.5, 400), [0.0, 1.0, 0.999999, 1e-300]])
    f = np.where(rng.uniform(size=delta.size) < 0.5, 0.0, rng.uniform(0, 1, delta.size))
    got = np.array(rigid_coefficients(delta, f)).T
    for row, dl, fr in zip(got, delta, f):
        p = RigidZOH(delta=float(dl), d=0, f=float(fr))
        want = np.array(p.coefficients() + p.f0_numerator())
        # c(δ) ≈ −δ/6 is a difference of O(1/δ) terms above δ = 1: a few ulp of those
        np.testing.assert_allclose(row, want, rtol=8e-16 if dl < 1 else 1e-14, atol=0)
    ds = np.concatenate([rng.uniform(0, 50, 300), [0.003 / 0.001, 2.9999999, 7.0, 0.0, 1e4 - 1e-13]])
    whole, frac = split_delay_array(ds)
    assert [(int(a), float(b)) for a, b in zip(whole, frac)] == [split_delay(float(x)) for x in ds]


def test_cable_plant_zeros_found_when_asked_are_the_eager_ones():
    """Issue 32: a cable plant keeps its zeros' polynomial and finds them when zero_angles() is first asked; they are
    the bits the eager np.roots gave (the anti-resonance of G_r, as angles per sample), and cached."""
    import numpy as np

    from models.device import Device
    from models.discretize import fold_angle
    from models.plants import stiffness_loop_plant

    for preset, delay in (("lhifam", 0.0), ("lhifam", 0.0037)):
        dev = Device(preset=preset, delay=delay)
        c, t = dev.cable, dev.sample_time
        eager = tuple(float(abs(z.imag)) for z in np.roots([c.body_mass, c.body_damping + c.damping, c.stiffness]) * t)
        plant = stiffness_loop_plant(dev)
        assert "zeros" not in plant._cache
        assert plant.zero_hints() == eager and len(eager) == 2 and eager[0] > 0.0
        assert plant.zero_angles() == tuple(fold_angle(abs(w)) for w in eager)
        assert plant._cache["zeros"] is plant.zero_hints()
