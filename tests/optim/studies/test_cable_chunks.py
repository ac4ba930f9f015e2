"""optim.studies.cable_chunks: a chunk's damped cable points, grouped by everything but the delay, give the numbers
optim.robust.batch gave them (bit for bit), and the swap point sees each group whole."""

from __future__ import annotations

import numpy as np

from models.device import Device
from optim.robust.batch import batch_critical_stiffness
from optim.studies.cable_chunks import cable_group_critical, critical_arrays, group_key
from optim.studies.critical_study import evaluate_batch

CABLE = {"motor_mass": 0.3, "motor_damping": 0.1, "body_mass": 5.1, "body_damping": 3.4, "stiffness": 79500.0,
         "damping": 15.0}
UNDAMPED = {**CABLE, "motor_damping": 0.0, "body_damping": 0.0, "damping": 0.0}


def _chunk():
    devs, b = [], []
    for stiffness in (4e4, 79500.0):
        for delay in (0.0, 0.0037, 0.012):
            for damping in (0.0, 3.0):
                devs.append(Device(cable={**CABLE, "stiffness": stiffness}, delay=delay))
                b.append(damping)
    devs += [Device(mass=5.4, damping=3.5, delay=0.0025), Device(cable=UNDAMPED, delay=0.002)]
    b += [2.0, 0.0]
    return devs, np.array(b)


def test_grouped_chunk_equals_the_batch_path_bit_for_bit():
    devs, b = _chunk()
    with np.errstate(all="ignore"):      # the undamped cable's scan meets 1/0 at its poles, as in a study
        got, ref = critical_arrays(devs, b), batch_critical_stiffness(devs, b)
    for name in ("critical_stiffness", "crossover_angle", "max_stable_damping"):
        x, y = getattr(got, name), getattr(ref, name)
        assert np.array_equal(x, y, equal_nan=True), name
    assert np.all(got.critical_stiffness[:-2] > 0)


def test_the_swap_point_gets_each_group_whole_and_its_answers_land_on_their_rows():
    devs, b = _chunk()
    seen = []

    def spy(base, delays, damping):
        seen.append((group_key(base), list(delays), list(damping)))
        return cable_group_critical(base, delays, damping)

    with np.errstate(all="ignore"):
        got = critical_arrays(devs, b, spy)
        ref = batch_critical_stiffness(devs, b)
    assert len(seen) == 2                                    # two cable stiffnesses: two groups
    assert {len(d) for _, d, _ in seen} == {6}               # 3 delays × 2 B each
    assert len({k for k, _, _ in seen}) == 2
    assert np.array_equal(got.critical_stiffness, ref.critical_stiffness)


def test_a_study_chunk_hands_every_damped_cable_of_the_chunk_to_one_class():
    """by_delay_class keeps a chunk's damped cables together whatever their delays (0 … 12 samples here), so a
    group holds every delay of its cable."""
    import optim.studies.cable_chunks as cc

    devs, b = _chunk()
    calls = []
    orig = cc.cable_group_critical

    def spy(base, delays, damping):
        calls.append(len(delays))
        return orig(base, delays, damping)

    cc.cable_group_critical = spy
    try:
        out = evaluate_batch(devs, [{"damping": float(x)} for x in b])
    finally:
        cc.cable_group_critical = orig
    assert sorted(calls) == [6, 6]
    assert all(err is None for _, err in out)
