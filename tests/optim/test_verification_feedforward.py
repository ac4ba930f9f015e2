"""optim.transparency.closed_loop_feedforward / verify of K_f,cr against tests/optim/closed_loop.py (its own filter
state space and shift register) and on random feedforward devices."""

from __future__ import annotations

import numpy as np
import pytest

from models.device import Device, Human
from models.feedforward import feedforward_plant
from models.filters import ButterworthLowPass
from optim.stability.closed_loop import radius_excess
from optim.transparency.closed_loop_feedforward import (
    feedforward_closed_loop,
    feedforward_loop,
    feedforward_unstable_count,
)
from optim.transparency.feedforward_ladder import analyse_force_feedforward
from optim.verification import verify_critical_force_gain, verify_force_feedforward
from tests.optim.closed_loop import spectral_radius

HUMAN = Human(mass=2.0, damping=2.0, stiffness=10.0)


@pytest.mark.parametrize("delay", [0.0, 0.0015, 0.004])
@pytest.mark.parametrize("cable", [False, True])
def test_radius_and_count_match_the_test_side_closed_loop(delay, cable):
    dev = Device(preset="lhifam", delay=delay) if cable else Device(mass=5.4, damping=3.5, delay=delay,
                                                                      human=HUMAN.model_dump())
    filt = ButterworthLowPass(2, 30.0, dev.sample_time)
    loop = feedforward_loop(dev, HUMAN, 2, 30.0)
    for kf in (0.5, 3.0, 8.0, 20.0, 60.0):
        ref = spectral_radius(feedforward_plant(dev, HUMAN), kf, filt)
        assert 1.0 + radius_excess(feedforward_closed_loop(loop, kf)).excess == pytest.approx(ref, abs=1e-10)
        if abs(ref - 1.0) > 1e-9:
            assert (feedforward_unstable_count(loop, kf).count == 0) == (ref < 1.0)


def test_a_wrong_force_gain_is_contradicted():
    dev = Device(preset="lhifam", delay=0.001)
    a = analyse_force_feedforward(dev, ButterworthLowPass(2, 30.0, dev.sample_time))
    assert verify_force_feedforward(dev, a, 2, 30.0).verdict == "confirmed"
    for wrong in (a.critical_force_gain * 1.01, a.critical_force_gain * 0.99):
        assert verify_critical_force_gain(dev, a.human, wrong, 2, 30.0).verdict == "contradicted"


@pytest.mark.slow
def test_exact_force_gains_confirmed_on_random_devices():
    rng = np.random.default_rng(33)
    verdicts = []
    for _ in range(80):
        t = 10 ** rng.uniform(-4, -2.5)
        human = {"mass": rng.uniform(0.1, 4), "damping": rng.uniform(0, 10), "stiffness": rng.choice([0.0, 10.0, 300.0])}
        sensor = {"time_constant": rng.choice([0.0, 10 ** rng.uniform(-4, -2)])}
        delay = rng.choice([0.0, rng.uniform(0, 5), rng.uniform(0, 600)]) * t
        if rng.random() < 0.5:
            dev = Device(mass=rng.uniform(0.5, 10), damping=rng.uniform(0.01, 10), sample_time=t, delay=delay,
                         human=human, force_sensor=sensor)
        else:
            dev = Device(preset="lhifam", sample_time=t, delay=delay, human=human, force_sensor=sensor)
        cutoff = rng.uniform(5, min(100, 0.3 / t))
        order = int(rng.integers(1, 5))
        a = analyse_force_feedforward(dev, ButterworthLowPass(order, cutoff, t))
        v = verify_force_feedforward(dev, a, order, cutoff)
        verdicts.append(v.verdict)
        assert v.verdict != "contradicted", (dev, order, cutoff, a.critical_force_gain, v)
    assert verdicts.count("not_checkable") <= 4, verdicts
