"""optim.stability.cable_batch against optim.stability.margins, device by device: the same K_cr, binding crossover,
B_max and path, to the bit, on random damped cables (tests/optim/stability/random_cables.py: whole and fractional
delays up to 200 samples, cable damping 1e-9–10× critical, so some rows are handed to margins) at B = 0, below
B_max, near it and past it, an undamped cable and the LHifAM cable."""

from __future__ import annotations

import math

import numpy as np
import pytest

from models.device import Device
from optim.errors import InputError
from optim.stability.cable_batch import cable_critical_stiffness_batch
from optim.stability.margins import critical_stiffness, max_stable_damping
from tests.optim.stability.random_cables import random_cable


def _cases(n: int, seed: int) -> tuple[list[Device], np.ndarray]:
    rng = np.random.default_rng(seed)
    devs = [random_cable(rng, i, low=0, top=200, short_top=4) for i in range(n)]
    devs += [Device(preset="lhifam", delay=d) for d in (0.0, 0.0037, 0.05)]
    devs.append(Device(cable=dict(motor_mass=0.3, body_mass=5.1, motor_damping=0.0, body_damping=0.0,
                                  stiffness=79500.0, damping=0.0), sample_time=1e-3, delay=5e-3))
    fracs = [0.0, 0.3, 0.49, 0.7, 1.0 - 1e-8, 1.5]
    b = []
    for i, d in enumerate(devs):
        f = fracs[i % len(fracs)]
        if f == 0.0:
            b.append(0.0)
            continue
        bm = max_stable_damping(d) if d.cable.damping > 0 or d.damping > 0 else 1.0
        b.append(f * bm if math.isfinite(bm) else f * d.damping)
    return devs, np.array(b)


def test_batch_is_margins_row_by_row():
    devs, b = _cases(36, 5)
    got = cable_critical_stiffness_batch(devs, b)
    fast = 0
    for i, (dev, bi) in enumerate(zip(devs, b)):
        bm = max_stable_damping(dev)
        want = critical_stiffness(dev, float(bi), b_max=bm if bi > 0 else None)
        w = want.crossover_frequency
        assert got.critical_stiffness[i] == want.critical_stiffness, (i, dev, bi)
        if w is None:
            assert math.isnan(got.crossover_angle[i])
        else:
            assert got.crossover_angle[i] == w * dev.sample_time, (i, dev, bi)
        assert got.max_stable_damping[i] == bm, (i, dev)
        assert got.path[i] == want.path, (i, dev, bi)
        fast += got.path[i] == "fast"
    assert fast >= len(devs) // 2
    assert 0 < got.handed_off < len(devs)


def test_batch_refuses_rigid_devices_and_bad_damping():
    with pytest.raises(InputError):
        cable_critical_stiffness_batch([Device(mass=1.0, damping=1.0)], 0.0)
    with pytest.raises(InputError):
        cable_critical_stiffness_batch([Device(preset="lhifam")], -1.0)


def test_a_whole_delay_axis_shares_the_factoring_and_answers_as_margins():
    """A study's delay axis: one cable at whole delays (and one fractional part) shares one factored loop; every row
    is still margins' own answer."""
    base = dict(motor_mass=0.3, body_mass=5.1, motor_damping=2.0, body_damping=1.5, stiffness=79500.0, damping=3.0)
    devs = [Device(cable=base, sample_time=1e-3, delay=(d + f) * 1e-3) for d in range(0, 40, 3) for f in (0.0, 0.25)]
    b = np.array([0.0 if i % 3 == 0 else 0.2 * d.damping for i, d in enumerate(devs)])
    got = cable_critical_stiffness_batch(devs, b)
    for i, (dev, bi) in enumerate(zip(devs, b)):
        bm = max_stable_damping(dev)
        want = critical_stiffness(dev, float(bi), b_max=bm if bi > 0 else None)
        assert got.critical_stiffness[i] == want.critical_stiffness, (i, dev, bi)
        assert got.max_stable_damping[i] == bm
        assert got.path[i] == want.path


def test_rows_handed_off_in_a_group_take_its_plant_at_their_delay_and_answer_as_margins():
    """A grouped delay axis with B above half of B_max (rows margins answers): each such row is given its group's
    sampled plant moved to its own whole delay (cable_batch._at_whole_delay), which has loop_plant's numbers, and its
    answer is margins' own, bit for bit (issue 32: the handed-off rows no longer sample and diagonalise again)."""
    from optim.stability.cable_batch import _at_whole_delay
    from optim.stability.cable_loop import cable_loop
    from optim.stability.margins import loop_plant

    devs = [Device(preset="lhifam", delay=d * 1e-3) for d in (0, 2, 5, 9, 14, 20)]
    bms = [max_stable_damping(d) for d in devs]
    b = np.array([f * bm for bm in bms for f in (0.3, 0.6, 0.9)])
    rows = [d for d in devs for _ in range(3)]
    got = cable_critical_stiffness_batch(rows, b, groups=[0] * len(rows))
    assert got.handed_off >= len(devs)
    for i, (dev, bi) in enumerate(zip(rows, b)):
        want = critical_stiffness(dev, float(bi), b_max=max_stable_damping(dev))
        assert got.critical_stiffness[i] == want.critical_stiffness, (i, dev.delay, bi)
        assert got.max_stable_damping[i] == bms[i // 3]
        assert got.path[i] == want.path
    first = loop_plant(devs[0])
    assert cable_loop(first) is not None
    for dev in devs[1:]:
        moved, fresh = _at_whole_delay(first, loop_plant(dev).d), loop_plant(dev)
        for name in ("a", "b", "c"):
            assert np.array_equal(getattr(moved, name), getattr(fresh, name))
        assert (moved.d, moved.f, moved.zeros_hint, moved.zero_hints()) == (fresh.d, fresh.f, fresh.zeros_hint,
                                                                            fresh.zero_hints())
        assert "modal" in moved._cache
        for x, y in zip(moved.modal_form(), fresh.modal_form()):
            assert np.array_equal(x, y)
        if "cable_loop" in first._cache:
            got, want = moved._cache["cable_loop"], cable_loop(fresh)      # moved to d: what cable_loop builds at d
            assert (got is None) == (want is None)
            if want is not None:
                assert got == want and (got.s, got.d) == (want.s, want.d)
                for x, y in zip(got.arrays, want.arrays):
                    assert np.array_equal(x, y, equal_nan=True)
