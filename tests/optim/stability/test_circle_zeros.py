"""Velocity filters with zeros on the unit circle other than z = ±1: a moving average of n samples vanishes at every
e^{2πjk/n}, where h_B and h_M (optim.stability.rendered) have poles, not crossings (rendered_rigid.circle_zero_angles,
rendered.velocity_response's c(1 − wⁿ)/D form, real_crossings(poles=…)).

Checked against independent methods: the zeros against numpy's polynomial roots and mpmath; V next to them against
mpmath at 50 digits; every listed crossing a sign change of a finite Im h; B_max and K_cr of averages on the scanned
path (a 60-sample delay: beyond the certificate's degree) against closed-loop eigenvalues with the filter's states
(optim.stability.closed_loop_rendered, written from the filter's specification); the HTTP answer against both."""

from __future__ import annotations

import math
import warnings

import mpmath as mp
import numpy as np
import pytest

from bench.bench_pi_zero_properties import _reduced_verdict
from models.device import Device
from models.velocity_filter import LowPass, MovingAverage, TransferFunctionFilter, rendering
from optim.errors import InputError
from optim.stability import rendered as R
from optim.stability.closed_loop import sampled_plant
from optim.stability.closed_loop_rendered import rendered_closed_loop
from optim.stability.rendered_rigid import LOOP_B, LOOP_M, circle_zero_angles, rigid_real_crossings
from optim.verification import check_point
from tests.service.conftest import make_client

from .test_pi_zero import _mp_v  # V in 50-digit mpmath, the same reference

T = 1e-3
#: a 60-sample delay: p's degree exceeds rendered_rigid.MAX_DEGREE, so h_B and h_M are scanned
SCANNED = Device(mass=0.5, damping=2.0, sample_time=T, delay=0.06)
CERTIFIED = Device(mass=0.5, damping=2.0, sample_time=T, delay=0.0)


def _average(n: int, mass: float = 0.0):
    return rendering(MovingAverage(kind="moving_average", samples=n), mass, T)


def _tf(r: list[float]):
    """The transfer function whose R is ``r`` (normalised to R(1) = 1): N = (1 − w)·R/T."""
    r = np.asarray(r, dtype=float) / float(np.sum(r))
    num = np.convolve([1.0, -1.0], r) / T
    return TransferFunctionFilter(kind="transfer_function", numerator=[float(c) for c in num])


@pytest.mark.parametrize("n", [2, 3, 4, 7, 12, 13, 25, 40])
def test_an_averages_circle_zeros_are_its_roots_of_unity(n):
    """The angles in (0, π) are numpy's roots of R (all n − 1 on the circle within 1e-9, π apart for even n)."""
    vel = _average(n).velocity
    got = circle_zero_angles(vel)
    roots = np.roots(np.asarray(vel.r)[::-1])
    assert np.all(np.abs(np.abs(roots) - 1.0) < 1e-9)
    want = sorted(a for a in np.abs(np.angle(roots)) if 1e-9 < a < math.pi - 1e-9)
    assert len(got) == len(set(np.round(want, 9))) == (n - 1) // 2
    assert np.allclose(got, sorted(set(np.round(want, 12))), rtol=0, atol=1e-9)


def test_transfer_functions_circle_zeros_decided_or_refused():
    """A transfer function writing an average out has its zeros; random R (numpy: no root within 1e-6 of the
    circle) and R = (1 + w)²·(random) have none but π; R = (1 + w²)(2 + w) (zeros at ±π/2) is not decided: the
    scanned B_max is refused on ``velocity_filter`` (422), never listed from a scan that could take a pole."""
    assert circle_zero_angles(rendering(_tf([1.0] * 5), 0.0, T).velocity) == circle_zero_angles(_average(5).velocity)
    rng = np.random.default_rng(5)
    for _ in range(200):
        r = rng.uniform(0.1, 1.0, int(rng.integers(2, 12)))
        for rr in (r, np.convolve([1.0, 2.0, 1.0], r)):
            vel = rendering(_tf(list(rr)), 0.0, T).velocity
            roots = np.roots(np.asarray(vel.r)[::-1])
            off_pi = roots[np.abs(roots + 1.0) > 1e-4]
            if off_pi.size and np.min(np.abs(np.abs(off_pi) - 1.0)) < 1e-6:
                continue                      # (not met with this seed)
            assert circle_zero_angles(vel) == ()
    quarter = rendering(_tf(list(np.convolve([1.0, 0.0, 1.0], [2.0, 1.0]))), 0.0, T)
    assert circle_zero_angles(quarter.velocity) is None
    with pytest.raises(InputError) as exc:
        R.clear_caches()
        R.rendered_max_stable_damping(SCANNED, quarter)
    assert exc.value.field == "velocity_filter"


@pytest.mark.parametrize("n", [3, 4, 7, 12, 13, 25, 40])
def test_velocity_response_is_accurate_at_and_beside_every_zero(n):
    """c(1 − wⁿ) with nθ − 2πm reduced in extended precision: within 1e-14 of mpmath at each 2πk/n (the float
    nearest), one ulp either side and 1e-3 … 1e-14 (relative) off; Horner's R there is off by more than 1e-3."""
    vel = _average(n).velocity
    thetas = []
    for k in range(1, n // 2 + 1):
        p = 2.0 * math.pi * k / n
        thetas += [p, float(np.nextafter(p, 0.0)), float(np.nextafter(p, 4.0))]
        thetas += [p * (1.0 + s * 10.0 ** -e) for e in (3, 6, 9, 12, 14) for s in (1.0, -1.0)
                   if p * (1.0 + s * 10.0 ** -e) <= math.pi]
    thetas = np.array(thetas + [1e-5, 0.1, 1.0])
    got, horner = R.velocity_response(vel, thetas), vel.response(thetas)
    worst_horner = 0.0
    for t, g, hv in zip(thetas, got, horner):
        ref = _mp_v(vel, float(t))
        assert abs(g - ref) <= 1e-14 * abs(ref), (t, g, ref)
        worst_horner = max(worst_horner, abs(hv - ref) / abs(ref))
    assert worst_horner > 1e-3


def _poles(n: int) -> list[float]:
    return [2.0 * math.pi * k / n for k in range(1, (n + 1) // 2)]


def _sign_change(h, t: float) -> bool:
    """Im h changes sign across t (1e-10 either side) and h is finite there."""
    a, b = h(np.array([t * (1.0 - 1e-10), t * (1.0 + 1e-10)]))
    return bool(np.isfinite([a, b]).all() and a.imag * b.imag < 0.0)


@pytest.mark.parametrize("n", [3, 4, 6, 12, 16, 25, 31, 40])
def test_the_scan_lists_no_pole_and_every_crossing_is_a_sign_change(n):
    """h_B, h_M scanned (60-sample delay) at two virtual masses: no crossing within 1e-9 of a pole 2πk/n, each
    listed one a sign change of a finite Im h; the same with V by Horner (the poles' brackets dropped alone), where
    without ``poles`` a 25-sample average's scan lists 4π/25 and 18π/25 at h_B ≈ −5e15, −5e16 (checked)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        for mass in (0.0, 0.2):
            r = _average(n, mass)
            mu = mass / SCANNED.mass
            poles = R.loop_poles(r.velocity)
            assert rigid_real_crossings(R.loop_plant(SCANNED), r, LOOP_B, 0.0, 0.0, mu) is None
            for h, grid in ((R._b_loop(SCANNED, r, mu), R._grid(SCANNED, r, 0.0)),
                            (R._m_loop(SCANNED, r, 0.0, 0.05), R._grid(SCANNED, r, 0.05))):
                found = R.real_crossings(h, grid, R.v_zero_at_pi(r.velocity), poles)
                assert found
                for c in found:
                    assert all(abs(c.angle - p) > 1e-9 * p for p in _poles(n)), (c, n)
                    assert _sign_change(h, c.angle), (c, n)
            if mass == 0.0:
                plant = R.loop_plant(SCANNED)
                vel = r.velocity

                def horner(theta):
                    v = vel.response(theta)
                    return -plant.inverse_response(theta) / v
                grid = R._grid(SCANNED, r, 0.0)
                with np.errstate(all="ignore"):
                    kept = R.real_crossings(horner, grid, R.v_zero_at_pi(vel), poles)
                    bare = R.real_crossings(horner, grid, R.v_zero_at_pi(vel))
                assert all(abs(c.angle - p) > 1e-9 * p for c in kept for p in _poles(n))
                if n == 25:
                    assert any(abs(c.angle - 4.0 * math.pi / 25) < 1e-9 for c in bare)


@pytest.mark.parametrize("n, mass", [(3, 0.0), (12, 0.1), (16, -0.1), (25, 0.0), (40, 0.2)])
def test_scanned_b_max_and_k_cr_against_closed_loop_eigenvalues(n, mass):
    """B_max: the K = 0⁺ loop (eigenvalues of the closed loop with the average's states, z = 1 removed) stable at
    B_max·(1 − 1e-6), unstable at B_max·(1 + 1e-6); K_cr(B_max/2): stable at K_cr·(1 − 1e-6), unstable at
    K_cr·(1 + 1e-6) (optim.verification.check_point: eigenvalues, else the argument principle)."""
    spec = MovingAverage(kind="moving_average", samples=n)
    r = rendering(spec, mass, T)
    dev = SCANNED
    R.clear_caches()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        b_max = R.rendered_max_stable_damping(dev, r)
        assert math.isfinite(b_max) and b_max > 0.0
        plant = sampled_plant(dev)
        mu = mass / dev.mass

        def reduced(b: float) -> str:
            return _reduced_verdict(rendered_closed_loop(plant, spec, T, 0.0, b / dev.damping_scale, mu))
        assert (reduced(b_max * (1 - 1e-6)), reduced(b_max * (1 + 1e-6))) == ("stable", "unstable"), b_max
        b = 0.5 * b_max
        kc = R.rendered_critical_stiffness(dev, b, r).critical_stiffness
        assert math.isfinite(kc) and kc > 0.0
        beta = b / dev.damping_scale
        inside = check_point(dev, plant, kc * (1 - 1e-6) / dev.stiffness_scale, beta, (spec, mass)).stable
        outside = check_point(dev, plant, kc * (1 + 1e-6) / dev.stiffness_scale, beta, (spec, mass)).stable
        assert (inside, outside) == (True, False), kc


@pytest.mark.parametrize("n", [4, 13])
def test_the_certified_and_scanned_paths_agree_on_averages(n):
    """Without delay (the certificate closes) and with the scan forced, h_B's and h_M's crossings of a moving
    average agree (angles and values to 1e-9, directions exactly), none at a pole."""
    r = _average(n, 0.1)
    mu = 0.1 / CERTIFIED.mass
    plant = R.loop_plant(CERTIFIED)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        for loop, h, beta in ((LOOP_B, R._b_loop(CERTIFIED, r, mu), 0.0),
                              (LOOP_M, R._m_loop(CERTIFIED, r, 0.0, 0.05), 0.05)):
            fast = rigid_real_crossings(plant, r, loop, 0.0, beta, mu if loop == LOOP_B else 0.0)
            assert fast is not None
            scan = R.real_crossings(h, R._grid(CERTIFIED, r, beta), R.v_zero_at_pi(r.velocity),
                                    R.loop_poles(r.velocity))
            assert len(fast) == len(scan) > 0
            for (tf, vf, of), c in zip(fast, scan):
                assert tf == pytest.approx(c.angle, rel=1e-9) and vf == pytest.approx(c.value, rel=1e-9)
                assert of == c.outward
                assert all(abs(tf - p) > 1e-9 for p in _poles(n))


def test_the_stability_route_answers_as_the_functions_with_a_12_sample_average():
    """POST /v1/analysis/stability with a 12-sample average on the scanned device: 200, B_max and K_cr as the
    functions give them (checked against eigenvalues above), every crossover finite and positive."""
    spec = {"kind": "moving_average", "samples": 12}
    body = {"device": {"mass": SCANNED.mass, "damping": SCANNED.damping, "sample_time": T, "delay": SCANNED.delay},
            "controller": {"stiffness": 100.0, "damping": 5.0, "mass": 0.1, "velocity_filter": spec}}
    with make_client() as client:
        res = client.post("/v1/analysis/stability", json=body)
    assert res.status_code == 200, res.text
    j = res.json()
    r = rendering(MovingAverage(**spec), 0.1, T)
    R.clear_caches()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        assert j["max_stable_damping"] == pytest.approx(R.rendered_max_stable_damping(SCANNED, r), rel=1e-12)
        kc = R.rendered_critical_stiffness(SCANNED, 5.0, r)
    assert j["critical_stiffness"] == pytest.approx(kc.critical_stiffness, rel=1e-12)
    assert j["crossovers"] and all(math.isfinite(c["stiffness"]) and c["stiffness"] > 0 for c in j["crossovers"])


def test_a_butterworth_has_no_other_circle_zero():
    assert circle_zero_angles(rendering(LowPass(kind="low_pass", cutoff_hz=50.0, order=2), 0.0, T).velocity) == ()


def test_a_genuine_crossing_next_to_a_pole_is_kept():
    """A wall of the property run (bench/bench_pi_zero_properties.py, seed 32, wall 1276): a 30-sample average's
    h_M at M = 0 crosses the real axis at 2π/3·(1 + 9.95e-10), next to its pole at 2π/3 (h ≈ c/(θ − θ_p) + d with c
    almost real), μ ≈ −1.66e9.  It is listed, and Im h with V and A in mpmath (40 digits) changes sign across it (θ·(1 ± 1e-13))."""
    dev = Device(mass=25.51090179514382, damping=0.025905306586363683, sample_time=0.00038395469355095396,
                 delay=0.035323831806687765)
    r = rendering(MovingAverage(kind="moving_average", samples=30), 0.8146204202288145 * dev.mass, dev.sample_time)
    R.clear_caches()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        found = [c for c in R._mass_crossings(dev, r, 0.0) if abs(c.angle - 2.0 * math.pi / 3.0) < 1e-8]
    assert len(found) == 1
    c = found[0]
    assert abs(c.angle / (2.0 * math.pi / 3.0) - 1.0) > R.POLE_GAP and c.value == pytest.approx(-1.662e9, rel=1e-3)
    plant = R.loop_plant(dev)
    signs = []
    for rel in (-1e-13, 1e-13):
        t = c.angle * (1.0 + rel)
        x = complex(-plant.inverse_response(np.array([t]))[0])
        with mp.workdps(40):
            w = mp.exp(-1j * mp.mpf(t))
            h = mp.mpc(x) / ((1 - w ** 30) / 30 * (1 - w))
            signs.append(mp.sign(h.imag))
            assert abs(h.real / c.value - 1) < 1e-3
    assert signs[0] * signs[1] < 0


@pytest.mark.parametrize("n", [12, 25])
def test_the_workspace_walls_scan_lists_no_pole(n):
    """optim.workspace.wall_rendered.RenderedWall (always scanned) on one mode of the scanned device: no B or M
    crossing within 1e-9 of a pole, each a sign change, and B_max as the 1-DOF analysis (eigenvalue-checked above)."""
    from optim.workspace.wall_plant import WallModes
    from optim.workspace.wall_rendered import RenderedWall
    m, b = SCANNED.mass, SCANNED.damping
    r = _average(n, 0.1)
    wall = RenderedWall(WallModes((1 / m,), (b / m,)), T, SCANNED.delay, r)
    R.clear_caches()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        for found in (wall._damper_passages(), wall._damper_passages(wall.mu), wall._mass_passages(0.05)):
            assert found
            assert all(abs(c.angle - p) > 1e-9 * p for c in found for p in _poles(n))
        assert wall.max_stable_damping() == pytest.approx(R.rendered_max_stable_damping(SCANNED, r), rel=1e-9)
