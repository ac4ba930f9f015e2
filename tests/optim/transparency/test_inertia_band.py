"""Inertia designs next to a jump of K_f,cr(f_c) (issue 17), checked by a dense cutoff scan and closed-loop poles.

K_f,cr jumps where a pair of crossovers vanishes tangentially as the cutoff rises: below the jump the pair sets
a low K_f,cr, above it the next crossover a much higher one.  The 17-point Pareto scan straddles the jump, so
before optim/transparency/inertia_band.py the design kept a scan point 1-5 % below the band's maximum, and a target between
the two was called infeasible.  The devices below came out of a random search for exactly that (the issue's
own devices were not given in full): a rigid one at T = 2 ms, like the issue's, and a cable one; and the
issue's cable device, its missing parameters reconstructed from the issue's numbers.

Independent checks: a dense exact scan of the band (optim.transparency.feedforward at 300 cutoffs, not the design's
search), and the spectral radius of the closed-loop state matrix (tests/optim/closed_loop.py: scipy's
Butterworth, no frequency response).
"""

import math

import numpy as np
import pytest

from models.device import Device
from models.feedforward import feedforward_plant
from models.filters import ButterworthLowPass
from optim.transparency.feedforward import critical_force_gain_of_plant
from optim.transparency.inertia import InertiaRequirements, design_inertia, upper_cutoff_hz
from tests.optim.closed_loop import spectral_radius

pytestmark = pytest.mark.slow

RIGID_JUMP = Device(mass=1.029985459024432, damping=2.9662632966274485, sample_time=0.002, delay=0.004,
                    human={"mass": 0.07437381196040094, "damping": 2.961499997837337, "stiffness": 207.9300885436179},
                    force_sensor={"time_constant": 0.0})
CABLE_JUMP = Device(sample_time=0.001, delay=0.005,
                    cable={"motor_mass": 0.13083075775577963, "motor_damping": 0.1, "body_mass": 1.2976995679619583,
                           "body_damping": 3.4, "stiffness": 40337.893360381364, "damping": 3.670580004984369},
                    human={"mass": 0.3249975817141055, "damping": 0.8204500601562204, "stiffness": 207.4975656200832},
                    force_sensor={"time_constant": 0.0})
# Issue 17's cable device (m_r 0.268, m_d 7.87, k_c 47.2 kN/m, b_c 24.1, a 0.166 kg hand, T_f = 1 ms, 3rd order,
# 3 dB), the missing parameters the LHifAM's (b_r 0.1, b_d 3.4, T = 1 ms, no delay) except the hand's damping and
# stiffness, solved for the issue's two numbers (to 1.3e-4): K_f,cr = 116.15 at the scan point 11.27 Hz and 118.13
# at 10.49 Hz.  Its jump is at 10.4797 Hz: 15.5 below, 118.14 above.
ISSUE_CABLE = Device(sample_time=0.001,
                     cable={"motor_mass": 0.268, "motor_damping": 0.1, "body_mass": 7.87, "body_damping": 3.4,
                            "stiffness": 47200.0, "damping": 24.1},
                     human={"mass": 0.166, "damping": 0.8861727, "stiffness": 48.322562},
                     force_sensor={"time_constant": 0.001})
# (device, filter order, margin [dB], jump [Hz], K_f,cr just above it, the 17-point scan's best): dense scan, 3000 cutoffs
JUMPS = {"rigid": (RIGID_JUMP, 4, 3.0, 19.8655, 18.0003, 17.8071),
         "cable": (CABLE_JUMP, 3, 6.0, 23.6702, 7.2020, 6.8101),
         "issue-cable": (ISSUE_CABLE, 3, 3.0, 10.4797, 118.13, 116.15)}
OBJECTIVE_RTOL = 1e-3   # property test: no dense-scan cutoff beats the design's K_f,cr by more than this


def dense(dev: Device, order: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    hi, _ = upper_cutoff_hz(dev)
    plant = feedforward_plant(dev, dev.human)
    cs = np.geomspace(10.0, hi, n)
    return cs, np.array([critical_force_gain_of_plant(plant, 2 * math.pi * c * dev.sample_time, order)[0]
                         for c in cs])


def radius(dev: Device, gain: float, cutoff_hz: float, order: int) -> float:
    return spectral_radius(feedforward_plant(dev, dev.human), gain,
                           ButterworthLowPass(order, cutoff_hz, dev.sample_time))


@pytest.mark.parametrize("name", JUMPS)
def test_min_apparent_mass_takes_the_high_side_of_the_jump(name):
    dev, order, gm, jump_hz, k_above, k_scan = JUMPS[name]
    d = design_inertia(dev, InertiaRequirements(filter_order=order, min_gain_margin_db=gm))
    assert d.status == "optimal"
    assert d.critical_force_gain >= k_above * (1 - 1e-5) and d.critical_force_gain > k_scan * 1.01
    assert d.filter_cutoff_hz == pytest.approx(jump_hz, rel=1e-4)
    assert any(lo <= d.filter_cutoff_hz <= hi * (1 + 1e-12) for lo, hi in d.solver["crossover_structure_changes_hz"])
    _, ks = dense(dev, order, 300)
    assert d.critical_force_gain >= ks.max() * (1 - 1e-9)
    # eigenvalues: the design is stable and its K_f,cr is where the loop goes unstable; 1e-6 below the jump
    # the vanishing pair sets a K_f,cr 25-65 % lower, and the poles confirm it destabilises there too (in a narrow
    # window: the pair's two gains nearly coincide, so the loop is unstable only between them)
    kf, kcr, fc = d.force_gain, d.critical_force_gain, d.filter_cutoff_hz
    assert radius(dev, kf, fc, order) < 1.0
    assert radius(dev, kcr * (1 - 1e-6), fc, order) < 1.0 < radius(dev, kcr * (1 + 1e-6), fc, order)
    below = fc * (1 - 1e-6)
    k_below = critical_force_gain_of_plant(feedforward_plant(dev, dev.human), 2 * math.pi * below * dev.sample_time,
                                           order)[0]
    assert k_below < 0.8 * kcr
    assert radius(dev, k_below * (1 - 1e-6), below, order) < 1.0 < radius(dev, k_below * (1 + 1e-6), below, order)


@pytest.mark.parametrize("name", JUMPS)
def test_target_reached_only_past_the_jump_is_feasible(name):
    dev, order, gm, jump_hz, k_above, k_scan = JUMPS[name]
    rho = 10 ** (gm / 20)
    need = 0.5 * (k_scan + k_above)                       # above every scan point, below the maximum
    target = dev.mass / (1 + need / rho)
    d = design_inertia(dev, InertiaRequirements(filter_order=order, min_gain_margin_db=gm, target_apparent_mass=target))
    assert d.status == "optimal", d.reason
    assert d.filter_cutoff_hz > jump_hz * (1 - 1e-4) and d.gain_margin_db >= gm - 1e-6
    kf = d.force_gain
    # eigenvalues: ρ·K_f is stable at every cutoff from the jump to the design's, and not just beyond it
    for fc in np.linspace(jump_hz * (1 + 1e-4), d.filter_cutoff_hz, 5):
        assert radius(dev, rho * kf * (1 - 1e-9), fc, order) < 1.0, fc
    assert radius(dev, rho * kf, d.filter_cutoff_hz * 1.002, order) > 1.0
    # the dense scan finds no feasible cutoff above the design's
    cs, ks = dense(dev, order, 300)
    assert not np.any((ks >= rho * kf) & (cs > d.filter_cutoff_hz * (1 + 1e-9)))


@pytest.mark.parametrize("name", JUMPS)
def test_unreachable_target_states_the_true_maximum(name):
    dev, order, gm, _, k_above, _ = JUMPS[name]
    rho = 10 ** (gm / 20)
    target = dev.mass / (1 + 1.01 * k_above / rho)
    d = design_inertia(dev, InertiaRequirements(filter_order=order, min_gain_margin_db=gm, target_apparent_mass=target))
    assert d.status == "infeasible"
    best = design_inertia(dev, InertiaRequirements(filter_order=order, min_gain_margin_db=gm))
    assert "the largest K_f,cr in [10, " in d.reason and f"is {best.critical_force_gain:.6g} at " in d.reason
    assert d.critical_force_gain == pytest.approx(best.critical_force_gain, rel=1e-9)


def _random_device(rng: np.random.Generator) -> Device:
    t = float(rng.choice([0.0005, 0.001, 0.002]))
    human = {"mass": 10 ** rng.uniform(-1.2, 0.5), "damping": rng.uniform(0, 10), "stiffness": 10 ** rng.uniform(0, 2.5)}
    common = dict(sample_time=t, delay=t * float(rng.choice([0, 1, 2, 3, 5])), human=human,
                  force_sensor={"time_constant": float(rng.choice([0.0, 0.001, 0.005]))})
    if rng.random() < 0.5:
        return Device(mass=10 ** rng.uniform(0, 1), damping=rng.uniform(0, 10), **common)
    return Device(cable={"motor_mass": 10 ** rng.uniform(-1, 0), "motor_damping": rng.uniform(0, 1),
                         "body_mass": 10 ** rng.uniform(0, 1), "body_damping": rng.uniform(0, 5),
                         "stiffness": 10 ** rng.uniform(4, 5.3), "damping": rng.uniform(1, 30)}, **common)


@pytest.mark.slow
def test_property_no_dense_cutoff_beats_the_design():
    """Random rigid and cable devices: no cutoff of a dense scan (300 cutoffs) beats the min-apparent-mass design's
    K_f,cr by more than OBJECTIVE_RTOL, and a target the dense scan can meet is never called infeasible and gets
    a cutoff at least as high as the dense scan's highest feasible one."""
    rng = np.random.default_rng(17)
    checked = 0
    while checked < 14:
        dev = _random_device(rng)
        order, gm = int(rng.integers(1, 5)), float(rng.choice([3.0, 6.0]))
        if upper_cutoff_hz(dev)[0] <= 12.0:
            continue
        cs, ks = dense(dev, order, 300)
        if not np.all(np.isfinite(ks)):
            continue
        checked += 1
        d = design_inertia(dev, InertiaRequirements(filter_order=order, min_gain_margin_db=gm))
        assert d.status == "optimal" and ks.max() <= d.critical_force_gain * (1 + OBJECTIVE_RTOL), dev
        rho = 10 ** (gm / 20)
        need = ks.max() * rng.uniform(0.85, 0.999)
        t = design_inertia(dev, InertiaRequirements(filter_order=order, min_gain_margin_db=gm,
                                                    target_apparent_mass=dev.mass / (1 + need / rho)))
        assert t.status == "optimal", (dev, t.reason)
        need = rho * t.force_gain              # as the design rounded it
        assert cs[ks >= need * (1 + 1e-9)].max(initial=0.0) <= t.filter_cutoff_hz * (1 + 1e-9), dev


def test_issue_cable_numbers():
    """The issue's report: the 17-point scan's best is 116.15 at 11.27 Hz, K_f,cr reaches 118.13 at 10.49 Hz, and
    a target between them (0.0975 kg: K_f,cr ≥ 116.49 needed) is met from the jump up to ~11.1 Hz, not infeasible;
    the min-apparent-mass design is 1.7 % lighter than the scan's best point."""
    dev = ISSUE_CABLE
    d = design_inertia(dev, InertiaRequirements(filter_order=3, min_gain_margin_db=3.0))
    assert d.pareto[1].filter_cutoff_hz == pytest.approx(11.27, abs=0.005)
    assert d.pareto[1].critical_force_gain == pytest.approx(116.15, rel=2e-4)   # the reconstruction's fit
    assert max(p.critical_force_gain for p in d.pareto) == d.pareto[1].critical_force_gain
    assert d.critical_force_gain == pytest.approx(118.13, rel=2e-4) and d.filter_cutoff_hz == pytest.approx(10.48, abs=0.005)
    assert d.apparent_mass < 0.984 * d.pareto[1].apparent_mass
    t = design_inertia(dev, InertiaRequirements(filter_order=3, min_gain_margin_db=3.0, target_apparent_mass=0.0975))
    assert t.status == "optimal" and 10.96 < t.filter_cutoff_hz < 11.27
    rho = 10 ** (3 / 20)
    for fc in (10.49, 10.7, 10.96, t.filter_cutoff_hz):        # eigenvalues: ρ·K_f is stable at each cutoff
        assert radius(dev, rho * t.force_gain * (1 - 1e-9), fc, 3) < 1.0, fc
