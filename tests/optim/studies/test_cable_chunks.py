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
    group holds every delay of its cable; every group goes to ONE cable batch call, told its groups."""
    import optim.studies.cable_chunks as cc

    devs, b = _chunk()
    calls = []
    orig = cc.cable_critical_stiffness_batch

    def spy(devices, damping, groups=None):
        calls.append(list(groups))
        return orig(devices, damping, groups=groups)

    cc.cable_critical_stiffness_batch = spy
    try:
        out = evaluate_batch(devs, [{"damping": float(x)} for x in b])
    finally:
        cc.cable_critical_stiffness_batch = orig
    assert len(calls) == 1
    assert sorted(calls[0].count(g) for g in set(calls[0])) == [6, 6]
    assert all(err is None for _, err in out)


def test_the_grouped_call_equals_the_group_by_group_swap_point_bit_for_bit():
    """A grid of whole and fractional delays (several points per fractional part, several B per point): one call
    told the groups gives cable_group_critical's numbers group by group, and the ungrouped batch's."""
    from optim.stability.cable_batch import cable_critical_stiffness_batch

    devs, b = [], []
    for stiffness, damping in ((4e4, 15.0), (79500.0, 6.0), (79500.0, 15.0)):
        for delay in (0.0, 0.001, 0.0025, 0.0035, 0.003, 0.0125):
            for virtual in (0.0, 2.0, 30.0):
                devs.append(Device(cable={**CABLE, "stiffness": stiffness, "damping": damping}, delay=delay))
                b.append(virtual)
    b = np.array(b)
    with np.errstate(all="ignore"):
        chunk = critical_arrays(devs, b)
        by_group = critical_arrays(devs, b, cable_group_critical)
        flat = cable_critical_stiffness_batch(devs, b)
    for name in ("critical_stiffness", "crossover_angle", "max_stable_damping"):
        assert np.array_equal(getattr(chunk, name), getattr(by_group, name), equal_nan=True), name
        assert np.array_equal(getattr(chunk, name), getattr(flat, name), equal_nan=True), name
    assert np.all(chunk.critical_stiffness[b < 30.0] > 0)


def test_group_key_with_a_memo_of_blocks_is_the_key_without_it():
    """critical_arrays' memo (blocks by id) keys every device as group_key alone does: the delay left out, a zero's
    sign kept, a shared cable block keyed once, and devices that differ anywhere but the delay apart."""
    base = Device(cable=CABLE, delay=0.003)
    devs = [base, base.model_copy(update={"delay": 0.011}), base.model_copy(update={"delay": 0.0}),
            Device(cable={**CABLE, "damping": 0.0}, delay=0.003), Device(cable={**CABLE, "damping": -0.0}),
            Device(cable={**CABLE, "motor_damping": 0.0}), Device(cable={**CABLE, "motor_damping": -0.0}),
            Device(cable=CABLE, delay=0.003, sample_time=0.0005), Device(mass=5.4, damping=3.5, delay=0.002)]
    memo: dict[int, object] = {}
    keys = [group_key(d, memo) for d in devs]
    assert keys == [group_key(d) for d in devs]
    assert keys[0] == keys[1] == keys[2]
    assert len(set(keys[2:])) == len(devs) - 2


def test_rows_as_base_and_delay_equal_the_devices_bit_for_bit():
    """Issue 32: cable_batch.cable_critical_stiffness_grouped and cable_chunks.grouped_arrays (rows given as a base
    device and a delay, no Device per row) answer what cable_critical_stiffness_batch answers for the Devices
    with_delay(base, delay), each alone (its own plant sampled): K_cr, ωT, B_max and each row's path, by bits.
    The rows hold whole and fractional delays, bases equal by value but distinct objects (one group), a base whose
    own delay is none of its rows', and B from 0 to past B_max (rows handed to margins, "dead" rows)."""
    from models.device import with_delay
    from optim.stability.cable_batch import cable_critical_stiffness_batch, cable_critical_stiffness_grouped
    from optim.studies.cable_chunks import grouped_arrays

    bases = [Device(cable={**CABLE, "stiffness": 4e4}, delay=0.0123),
             Device(cable={**CABLE, "stiffness": 79500.0}),
             Device(cable={**CABLE, "stiffness": 79500.0}),          # equal to the one before: one group
             Device(cable={**CABLE, "stiffness": 2.2e5, "damping": 2.0}, sample_time=0.0005)]
    bmax = [float(cable_critical_stiffness_batch([b]).max_stable_damping[0]) for b in bases]
    rng = np.random.default_rng(7)
    base_of, delays, damping = [], [], []
    for j in range(len(bases)):
        for delay in (0.0, 0.001, 0.0025, 0.0037, 0.004, 0.012):
            for frac in (0.0, 0.2, 0.49, 0.51, 0.9, 0.999, 1.0, 1.3):
                base_of.append(j)
                delays.append(delay)
                damping.append(frac * bmax[j] if frac else 0.0)
    order = rng.permutation(len(base_of))                      # rows of one group apart, as any chunk may have them
    base_of, delays, damping = (np.array(x)[order] for x in (base_of, delays, damping))
    devices = [with_delay(bases[j], float(d)) for j, d in zip(base_of, delays)]
    ref = cable_critical_stiffness_batch(devices, damping)
    got = cable_critical_stiffness_grouped(bases, base_of, delays, damping)
    arr = grouped_arrays(bases, base_of, delays, damping)
    for name in ("critical_stiffness", "crossover_angle", "max_stable_damping"):
        x, y, z = getattr(got, name), getattr(ref, name), getattr(arr, name)
        assert x.tobytes() == y.tobytes() == z.tobytes(), name
    assert got.path == ref.path and got.handed_off == ref.handed_off
    assert ref.handed_off > 0 and "fast" in ref.path               # both kinds of rows are here
    assert np.any(ref.critical_stiffness == 0.0) and np.any(np.isfinite(ref.crossover_angle))
