"""The relay experiment: the cycles a lab can read, checked against the exact periodic solutions,
the exact pulse transfer (models/discretize) and the exact K_cr (optim.stability.margins).

Reference behaviour (FIELD-NOTES.md, measured while scoping; the chapter's Table 4 shows the same switch
between the resonance and the low crossover with delay): LHifAM rigid, no delay, 1 N relay, starts 1e-6,
1e-4, 3e-3 m → symmetric 88 (K_u ≈ 6884), wandering 91–101 (≈ 5813), symmetric 115 (≈ 4031); K_cr = 7001.
"""

import math

import numpy as np
import pytest

from models.device import Device
from models.plants import stiffness_loop_plant
from models.simulation.scene import Scene
from optim.relay.experiment import relay_experiment, relay_rung

STARTS = (1e-6, 1e-4, 3e-3)


def _run(dev, x0, eff, duration=30.0):
    return relay_experiment(dev, Scene(experiment="relay", duration=duration, relay={"amplitude": 1.0},
                                       initial={"position": x0}, effects=eff))


def _check_report(dev, rep):
    s = rep.settled
    assert s is not None
    if s.repeats:
        # the simulated settled cycle IS the exact periodic solution of its own pattern
        assert s.force_amplitude_error <= 1e-6 and s.position_amplitude_error <= 1e-6
        assert s.frequency_error <= 1e-6
        # and K_u = 1/|G(e^{jωT})| of the exact pulse transfer (models/discretize, independent code)
        g = stiffness_loop_plant(dev).response(np.array([s.exact.frequency * dev.sample_time]))[0]
        assert s.exact.ultimate_gain == pytest.approx(dev.stiffness_scale / abs(g), rel=1e-8)
        if s.symmetric:
            listed = {c.pattern[0]: c for c in rep.cycles}
            assert listed[s.pattern[0]].admissible
            assert listed[s.pattern[0]].ultimate_gain == pytest.approx(s.exact.ultimate_gain, rel=1e-9)
    else:
        assert s.exact is None and s.force_amplitude_error is None
        assert s.half_period_min < s.half_period_max
        assert s.ultimate_gain_min <= s.ultimate_gain_max


@pytest.mark.slow
def test_rigid_relay_cycles_depend_on_the_start():
    dev = Device(preset="lhifam", cable=None)
    reps = [_run(dev, x0, {}) for x0 in STARTS]
    for rep in reps:
        _check_report(dev, rep)
    a, b, c = (r.settled for r in reps)
    assert a.repeats and a.pattern == (88,) and a.ultimate_gain == pytest.approx(6884, rel=1e-3)
    assert not b.repeats and (b.half_period_min, b.half_period_max) == (91, 101)
    assert b.ultimate_gain == pytest.approx(5813, rel=0.02)     # a lab's spectral estimate of a wandering cycle
    assert c.repeats and c.pattern == (115,) and c.ultimate_gain == pytest.approx(4031, rel=1e-3)
    kcr = reps[0].critical_stiffness.critical_stiffness
    assert kcr == pytest.approx(7000.756, rel=1e-6)
    assert reps[0].ultimate_gain_error == pytest.approx(6883.7 / kcr - 1, abs=1e-4)
    assert reps[0].nearest_crossover.frequency == pytest.approx(reps[0].critical_stiffness.crossover_frequency)
    lo, hi = reps[0].admissible_gain_range
    assert lo <= 4031 and hi >= 6884


@pytest.mark.slow
@pytest.mark.parametrize("delay", [0.0, 0.001, 0.003])
def test_cable_relay_cycles_are_admissible_and_exact(delay):
    dev = Device(preset="lhifam", delay=delay)
    eff = {"cable_mode": {}, "delay": {}}
    reps = [_run(dev, x0, eff) for x0 in STARTS + (1e-8,)]
    for rep in reps:
        _check_report(dev, rep)
    # several starts, several different cycles
    assert len({round(r.settled.frequency, 3) for r in reps}) >= 2
    freqs = [r.settled.frequency for r in reps]
    crit = reps[0].critical_stiffness
    if delay <= 0.001:
        # from the smallest start the relay locks onto the cable resonance (~520-630 rad/s)
        assert 500 < freqs[0] < 650
        assert 500 < reps[0].nearest_crossover.frequency < 650
    else:
        # with 3 ms some start finds the low crossover, with K_u within ~2 % of the exact K_cr
        near = [r for r in reps if r.nearest_crossover.frequency == crit.crossover_frequency]
        assert near and min(abs(r.ultimate_gain_error) for r in near) < 0.02


def test_exact_symmetric_cycle_meets_its_own_switching_conditions_in_simulation():
    """Start the simulated relay exactly on a listed admissible cycle: it stays there."""
    dev = Device(preset="lhifam", cable=None)
    rep = _run(dev, 3e-3, {})
    c115 = next(c for c in rep.cycles if c.pattern == (115,))
    assert c115.admissible and c115.sign_margin > 0
    n88 = next(c for c in rep.cycles if c.pattern == (88,))
    # K_u of a symmetric cycle N is 1/|G(e^{jπ/N})|: cross-check with the exact pulse transfer
    g = stiffness_loop_plant(dev).response(np.array([math.pi / 88]))[0]
    assert n88.ultimate_gain == pytest.approx(dev.stiffness_scale / abs(g), rel=1e-8)


@pytest.mark.slow
def test_relay_rung_reports_spread_beside_exact_kcr():
    dev = Device(preset="lhifam", cable=None)
    rung = relay_rung(dev, amplitude=1.0, starts=STARTS, duration=20.0)
    assert rung.method == "experiment" and len(rung.ultimate_gains) == 3
    assert rung.spread[0] == pytest.approx(4031, rel=2e-3) and rung.spread[1] == pytest.approx(6884, rel=2e-3)
    assert rung.critical_stiffness == pytest.approx(7000.756, rel=1e-6)
    assert rung.elapsed > 0
