"""Scene simulation checked against independent methods: an ODE loop, closed forms, the exact K_cr."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from models.device import Device
from models.simulation.scene import MAX_SAMPLES_LINEAR, Scene
from models.simulation.simulate import check_cost, simulate
from optim.stability.margins import critical_stiffness

LHIFAM_RIGID = {"mass": 5.4, "damping": 3.5, "sample_time": 0.001}


def _ode_loop(cable, t_s, delay, k, b_wall, n, push, x0):
    """Independent sampled loop: the two-mass ODE of eq. 15-18 written here, solve_ivp (rtol 1e-12) between
    every switching instant, the command u[k] held on [kT + t_d, (k+1)T + t_d)."""
    m_r, b_r, m_d, b_d, k_c, b_c = (cable[key] for key in ("motor_mass", "motor_damping", "body_mass",
                                                            "body_damping", "stiffness", "damping"))

    def rhs(_t, s, fm, fh):
        xr, xd, vr, vd = s
        link = k_c * (xr - xd) + b_c * (vr - vd)
        return [vr, vd, (fm - b_r * vr - link) / m_r, (fh - b_d * vd + link) / m_d]

    cmds = []
    state = np.array([x0, x0, 0.0, 0.0])
    y_prev = x0
    xr_out = [x0]
    for kk in range(n):
        y = state[0]
        cmds.append(-k * y - b_wall * (y - y_prev) / t_s)
        y_prev = y
        t0, t1 = kk * t_s, (kk + 1) * t_s
        breaks = sorted({t0, t1} | {j * t_s + delay for j in range(kk + 1) if t0 < j * t_s + delay < t1})
        for a, b in zip(breaks[:-1], breaks[1:]):
            j = math.floor((0.5 * (a + b) - delay) / t_s + 1e-12)
            fm = cmds[j] if j >= 0 else 0.0
            sol = solve_ivp(rhs, (a, b), state, args=(fm, push(kk)), method="DOP853", rtol=1e-12, atol=1e-16)
            state = sol.y[:, -1]
        xr_out.append(state[0])
    return np.array(xr_out), np.array(cmds)


def test_exact_propagation_matches_independent_ode_integrator():
    dev = Device(preset="lhifam", delay=0.0014)
    cable = dev.cable.model_dump()
    n = 120
    scene = Scene(experiment="push", duration=n * 1e-3, controller={"stiffness": 2000.0, "damping": 5.0},
                  initial={"position": 1e-3}, push={"times": [0.0, 0.05], "forces": [0.0, 2.0]},
                  effects={"cable_mode": {}, "delay": {}}, output_points=5000)
    res = simulate(dev, scene)
    assert res.method == "exact-linear-recursion"
    push = lambda kk: float(np.interp(kk * 1e-3, [0.0, 0.05], [0.0, 2.0]))
    xr, cmds = _ode_loop(cable, 1e-3, 0.0014, 2000.0, 5.0, n, push, 1e-3)
    # DOP853 at rtol 1e-12 over 120 samples: agreement to ~1e-9 of the motion's scale (1 mm)
    np.testing.assert_allclose(res.record.motor_position, xr, rtol=0, atol=1e-12)
    np.testing.assert_allclose(res.record.command, cmds, rtol=0, atol=1e-8)


def test_linear_recursion_equals_sample_by_sample_loop():
    """The vectorised block recursion and the per-sample exact loop (saturation at 1e9 N, never active)."""
    dev = Device(preset="lhifam", delay=0.0023)
    base = dict(experiment="release", duration=3.0, controller={"stiffness": 1500.0, "damping": 2.0},
                initial={"position": 2e-3, "velocity": 0.01})
    a = simulate(dev, Scene(**base, effects={"cable_mode": {}, "delay": {}}))
    b = simulate(dev, Scene(**base, effects={"cable_mode": {}, "delay": {}, "saturation": {"max_force": 1e9}}))
    assert (a.method, b.method) == ("exact-linear-recursion", "exact-sampled-loop")
    # same matrices, different summation order: rounding only
    np.testing.assert_allclose(a.record.motor_position, b.record.motor_position, rtol=0, atol=1e-15)
    np.testing.assert_allclose(a.energy_generated, b.energy_generated, rtol=1e-9)


CASES = [("rigid", d) for d in range(6)] + [("cable", d) for d in range(6)]


@pytest.mark.parametrize("model,delay_samples", CASES)
def test_verdict_agrees_with_exact_critical_stiffness(model, delay_samples):
    dev = Device(preset="lhifam", delay=delay_samples * 1e-3)
    if model == "rigid":
        dev = dev.rigid()
    crit = critical_stiffness(dev)
    eff = {"delay": {}} | ({"cable_mode": {}} if model == "cable" else {})
    verdicts = {}
    for factor in (0.95, 1.05):
        scene = Scene(experiment="release", duration=12.0, controller={"stiffness": factor * crit.critical_stiffness},
                      initial={"position": 1e-3}, effects=eff)
        res = simulate(dev, scene)
        verdicts[factor] = res.verdict
    assert verdicts[0.95].state == "stable" and verdicts[0.95].growth_rate < 0
    assert verdicts[1.05].state == "unstable" and verdicts[1.05].growth_rate > 0
    # the growing oscillation is the crossover that sets K_cr (FFT peak, 5 % for a 6 s window)
    assert verdicts[1.05].frequency == pytest.approx(crit.crossover_frequency, rel=0.05)


def test_divergence_stops_the_run_and_says_so():
    dev = Device(**LHIFAM_RIGID)
    res = simulate(dev, Scene(experiment="release", duration=200.0, controller={"stiffness": 2e4},
                              initial={"position": 1e-3}))
    assert res.verdict.state == "unstable" and res.diverged_at is not None and res.samples_run < res.samples
    assert np.all(np.isfinite(res.trajectory.motor_position))


def test_only_named_effects_are_simulated_and_unnamed_device_blocks_are_listed():
    dev = Device(preset="lhifam", delay=0.003)
    res = simulate(dev, Scene(experiment="release", duration=0.5, controller={"stiffness": 500.0},
                              initial={"position": 1e-3}))
    assert res.effects_simulated == ("zoh", "sampling")
    assert {s.split(":")[0] for s in res.not_simulated} == {"delay", "cable", "human", "force_sensor"}
    res = simulate(dev, Scene(experiment="release", duration=0.5, controller={"stiffness": 500.0},
                              initial={"position": 1e-3},
                              effects={"delay": {}, "cable_mode": {}, "human": {}, "force_sensor_filter": {},
                                       "force_feedforward": {"gain": 2.0, "cutoff_hz": 20.0}}))
    assert set(res.effects_simulated) == {"zoh", "sampling", "delay", "cable_mode", "human",
                                          "force_sensor_filter", "force_feedforward"}
    assert res.not_simulated == () and res.method == "exact-linear-recursion"


def test_cost_limit_names_the_duration():
    dev = Device(**LHIFAM_RIGID)
    with pytest.raises(ValueError, match=r"^scene.duration: .*limit"):
        check_cost(dev, Scene(experiment="release", duration=(MAX_SAMPLES_LINEAR + 1) * 1e-3,
                              controller={"stiffness": 1.0}))
    with pytest.raises(ValueError, match=r"^scene.duration: .*event-integrator"):
        check_cost(dev, Scene(experiment="release", duration=30.0, controller={"stiffness": 1.0},
                              effects={"coulomb_friction": {"force": 1.0}}))


# --- Coulomb friction: closed forms for a mass with viscous and Coulomb friction ----------------------

def test_friction_coasting_stop_matches_closed_form():
    """m v' = -b v - c from v0: stops at t* = (m/b) ln(1 + v0 b/c) after x* = (m/b)(v0 - (c/b) ln(1 + v0 b/c)),
    then stays stuck (no force). K = B = 0, so the wall does nothing."""
    m, b, c, v0 = 5.4, 3.5, 2.0, 0.05
    dev = Device(mass=m, damping=b)
    res = simulate(dev, Scene(experiment="release", duration=0.5, controller={"stiffness": 0.0},
                              initial={"velocity": v0}, effects={"coulomb_friction": {"force": c}}))
    assert res.method == "event-integrator"
    x_stop = (m / b) * (v0 - (c / b) * math.log1p(v0 * b / c))
    t_stop = (m / b) * math.log1p(v0 * b / c)
    assert t_stop < 0.2
    # exact pieces and a located event: agreement to rounding of the matrix exponentials
    np.testing.assert_allclose(res.record.motor_position[-1], x_stop, rtol=1e-10)
    k_stop = int(t_stop / 1e-3) + 2
    assert np.all(res.record.motor_position[k_stop:] == res.record.motor_position[-1])


@pytest.mark.parametrize("force,moves", [(1.5, False), (3.0, True)])
def test_friction_breakaway_matches_closed_form(force, moves):
    """From rest, constant push F: stuck while F ≤ c; else x = ((F-c)/b)(t - (m/b)(1 - e^{-bt/m}))."""
    m, b, c = 5.4, 3.5, 2.0
    dev = Device(mass=m, damping=b)
    res = simulate(dev, Scene(experiment="push", duration=0.3, controller={"stiffness": 0.0},
                              push={"times": [0.0], "forces": [force]}, effects={"coulomb_friction": {"force": c}}))
    t = 0.3
    expected = ((force - c) / b) * (t - (m / b) * -math.expm1(-b * t / m)) if moves else 0.0
    np.testing.assert_allclose(res.record.motor_position[-1], expected, rtol=1e-10, atol=0)


@pytest.mark.slow
def test_friction_dissipates_the_energy_quantisation_injects():
    """Chapter §2 (Diolaiti et al., Abbott & Okamura): with q = 0.1 mm and K = 5000 N/m the linear wall
    (b > KT/2) settles, quantisation alone keeps a limit cycle fed by the wall (E_gen grows steadily),
    and Coulomb friction c = 0.5 N > Kq/2 = 0.25 N stops it with E_gen bounded."""
    dev = Device(**LHIFAM_RIGID)
    base = dict(experiment="release", controller={"stiffness": 5000.0}, initial={"position": 2e-3})
    q = {"quantization": {"resolution": 1e-4}}
    lin = simulate(dev, Scene(**base, duration=60.0))
    quant = simulate(dev, Scene(**base, duration=60.0, effects=q))
    fric = simulate(dev, Scene(**base, duration=20.0, effects=q | {"coulomb_friction": {"force": 0.5}}))
    e_q = quant.record
    assert quant.verdict.state == "limit_cycle"
    # energy keeps growing at a steady rate in the quantised run: each of the last three quarters adds
    # a similar amount, much more than the linear run's (which has nearly settled)
    quarters = np.diff(quant.trajectory.energy_generated[np.linspace(0, len(quant.trajectory.time) - 1, 5).astype(int)])
    assert np.all(quarters[1:] > 1e-3) and quarters[1:].max() < 1.5 * quarters[1:].min()
    assert lin.energy_generated_second_half < 0.05 * quant.energy_generated_second_half
    assert fric.verdict.state == "stable"
    assert fric.energy_generated_second_half == 0.0
    assert fric.energy_generated_max < 0.2 * quant.energy_generated
    assert e_q is not None


def test_force_feedforward_divides_mass_and_damping_by_one_plus_gain():
    """Eq. 28: with K_f the device feels m/(1+K_f), b/(1+K_f); a constant push F on a free device
    (K = 0) reaches the terminal velocity F(1 + K_f)/b once the sensor filter and D(z) have settled."""
    dev = Device(mass=5.4, damping=3.5, force_sensor={"time_constant": 0.005})
    kf, force = 2.0, 1.0
    res = simulate(dev, Scene(experiment="push", duration=30.0, controller={"stiffness": 0.0},
                              push={"times": [0.0], "forces": [force]},
                              effects={"force_sensor_filter": {},
                                       "force_feedforward": {"gain": kf, "cutoff_hz": 30.0, "order": 2}}))
    v_end = (res.record.motor_position[-1] - res.record.motor_position[-2]) / 1e-3
    # time constant m/b ≈ 1.5 s, 30 s = 19 of them: e^-19 ≈ 5e-9 left of the transient
    assert v_end == pytest.approx(force * (1 + kf) / 3.5, rel=1e-6)


def test_butterworth_filter_is_prewarped_at_its_cutoff():
    from models.simulation.sim_loop import feedforward_filter
    a, b, c, d = feedforward_filter(30.0, 2, 1e-3)
    def gain(theta):
        z = np.exp(1j * theta)
        return abs(c @ np.linalg.solve(z * np.eye(len(b)) - a, b) + d)
    assert gain(1e-9) == pytest.approx(1.0, rel=1e-9)
    # the bilinear transform prewarped at f_c keeps |D| = 1/√2 exactly at the cutoff
    assert gain(2 * math.pi * 30.0 * 1e-3) == pytest.approx(1 / math.sqrt(2), rel=1e-9)
