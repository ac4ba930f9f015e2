"""Damped cable points of a study chunk, grouped so that each group shares everything but the delay (issue 32).

A cable study sweeps e.g. ``device.cable.stiffness`` × ``device.delay`` × ``device.cable.damping``: consecutive
points of a chunk are the same cable at many delays (and virtual dampings).  This module groups a chunk's damped
cable points by their device without its delay (mass, damping, cable, sample time: what a cable's modal factoring
depends on) and answers every group of the chunk in ONE optim.stability.cable_batch.cable_critical_stiffness_batch
call told the groups: one compiled call for all the chunk's rows, each group's plant sampled and factored once per
fractional part of its delays (the whole delays share it).  Every point gets what optim.stability.margins answers
for that device alone (K_cr, the binding crossover's angle ωT and B_max), so a study's rows never depend on the
chunk they are in.

:func:`cable_group_critical` answers one group alone (a swap point: ``critical_arrays(..., group_critical)`` takes
the groups one by one through it); tests/optim/studies/test_cable_chunks.py holds the chunk-wide call, the group by
group one and the ungrouped batch to the same bits.

:func:`grouped_arrays` takes a chunk already held as rows (base device, delay) (optim.studies.cable_columns: no
Device per point, the plants not kept in margins.loop_plant's cache) and gives critical_arrays' numbers for them.

Undamped cables (every cable damping 0) are not grouped here: they stay with optim.robust.batch's scan.
"""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np
from pydantic import BaseModel

from models.device import Device
from optim.robust.batch import BatchCritical, batch_critical_stiffness
from optim.stability.cable_batch import cable_critical_stiffness_batch, cable_critical_stiffness_grouped
from optim.stability.undamped_cable import is_undamped_cable

__all__ = ["GroupCritical", "cable_group_critical", "is_grouped_cable", "group_key", "critical_arrays",
           "grouped_arrays"]

#: (base device, delays [s], virtual dampings B [N·s/m]) -> (K_cr [N/m], crossover angle ωT [rad], B_max [N·s/m])
GroupCritical = Callable[[Device, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]


def is_grouped_cable(device: Device) -> bool:
    """A cable with some damping: its points go through :func:`cable_group_critical`."""
    return device.cable is not None and not is_undamped_cable(device)


def group_key(device: Device, blocks: dict[int, object] | None = None) -> tuple:
    """What the points of one group share: the device without its delay (hashable, exact values: every field but the
    delay in the model's order, a nested block as its fields'; a zero float with its sign; no dump per point).

    ``blocks``: the caller's memo of nested blocks' keys by their id(), for devices it holds alive meanwhile (a chunk's
    devices copied with each delay share their cable block: its key is made once)."""
    if blocks is None:
        return tuple(_exact(v) for k, v in device.__dict__.items() if k != "delay")
    out: list[object] = []
    for k, v in device.__dict__.items():
        if k == "delay":
            continue
        if type(v) is float and v:               # _exact's value for a nonzero float, without the call
            out.append(v)
        elif isinstance(v, BaseModel):
            got = blocks.get(id(v))
            if got is None:
                got = blocks[id(v)] = _exact(v)
            out.append(got)
        else:
            out.append(_exact(v))
    return tuple(out)


def _exact(v: object) -> object:
    t = type(v)
    if t is float:
        return v if v else repr(v)          # -0.0 == 0.0: the zero's sign kept apart
    if v is None or t is str:
        return v
    if isinstance(v, BaseModel):
        return (t.__name__, *(x if type(x) is float and x else _exact(x) for x in v.__dict__.values()))
    return (t.__name__, repr(v))


def cable_group_critical(base: Device, delays: np.ndarray, damping: np.ndarray
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """K_cr [N/m], crossover angle ωT [rad] (nan when K_cr is 0 or inf) and B_max [N·s/m] of the damped cable
    ``base`` at each (delay [s], B [N·s/m]) pair: each point as optim.stability.margins answers it alone.

    By optim.stability.cable_batch.cable_critical_stiffness_grouped: one compiled call for the group's rows (the
    factored loop shared by the whole delays), margins' own answers for the rows it hands off."""
    if base.cable is None or is_undamped_cable(base):
        raise ValueError("cable_group_critical takes damped cable devices only")
    delays = np.asarray(delays, dtype=float)
    got = cable_critical_stiffness_grouped([base], np.zeros(len(delays), dtype=np.int64), delays,
                                           np.asarray(damping, dtype=float))
    return got.critical_stiffness, got.crossover_angle, got.max_stable_damping


def grouped_arrays(bases: Sequence[Device], base_of: np.ndarray, delays: np.ndarray,
                   damping: np.ndarray) -> BatchCritical:
    """:func:`critical_arrays` of the rows ``models.device.with_delay(bases[base_of[i]], delays[i])`` without a
    Device per row (issue 32: a study chunk's bases are its validated devices, one per set of non-delay values):
    bases equal but for their delay (group_key) are one group; every base must be a damped cable
    (:func:`is_grouped_cable`).  The numbers are critical_arrays' of those Devices (tests/service/
    test_studies_blocks.py, tests/optim/studies/test_cable_chunks.py)."""
    n = len(base_of)
    b = np.broadcast_to(np.asarray(damping, float), (n,)).copy()
    blocks: dict[int, object] = {}
    by_key: dict[tuple, int] = {}
    firsts: list[Device] = []
    group_of_base = np.empty(len(bases), dtype=np.int64)
    for j, dev in enumerate(bases):
        if not is_grouped_cable(dev):
            raise ValueError("grouped_arrays takes damped cable devices only")
        key = group_key(dev, blocks)
        g = by_key.get(key)
        if g is None:
            g = by_key[key] = len(firsts)
            firsts.append(dev)
        group_of_base[j] = g
    # the plants not kept (cache_plants=False): a study's chunk is the only one to ask for its groups' plants
    got = cable_critical_stiffness_grouped(firsts, group_of_base[np.asarray(base_of, dtype=np.int64)],
                                           np.asarray(delays, dtype=float), b, cache_plants=False)
    return BatchCritical(got.critical_stiffness, got.crossover_angle, got.max_stable_damping, 0)


def critical_arrays(devices: Sequence[Device], damping: np.ndarray,
                    group_critical: GroupCritical | None = None) -> BatchCritical:
    """optim.robust.batch.batch_critical_stiffness of a chunk, its damped cables taken group by group (the points
    sharing everything but the delay): through ``group_critical`` one group at a time when one is given, else every
    group in one cable_critical_stiffness_batch call told the groups (the same numbers as :func:`cable_group_critical`
    group by group; tests/optim/studies/test_cable_chunks.py)."""
    fn = group_critical or cable_group_critical
    n = len(devices)
    b = np.broadcast_to(np.asarray(damping, float), (n,)).copy()
    kcr, ang, bmax = np.full(n, np.inf), np.full(n, np.nan), np.full(n, np.inf)
    groups: dict[tuple, list[int]] = {}
    rest = []
    # group_key made once per set of field objects (ids of the objects of ``devices``, alive for this call): a chunk's
    # devices copied from one device with each delay share every other field's object; equal values held in other
    # objects only make the same key again
    blocks: dict[int, object] = {}
    by_ids: dict[tuple, tuple] = {}
    for i, dev in enumerate(devices):
        if is_grouped_cable(dev):
            fields = dict(dev.__dict__)
            del fields["delay"]
            ids = tuple(map(id, fields.values()))
            key = by_ids.get(ids)
            if key is None:
                key = by_ids[ids] = group_key(dev, blocks)
            groups.setdefault(key, []).append(i)
        else:
            rest.append(i)
    scanned = 0
    if rest:
        sub = batch_critical_stiffness([devices[i] for i in rest], b[rest])
        kcr[rest], ang[rest], bmax[rest] = sub.critical_stiffness, sub.crossover_angle, sub.max_stable_damping
        scanned = sub.scanned
    if group_critical is None and groups:
        # every group of the chunk in one call (one compiled call for all their rows), each group's plant sampled
        # once per fractional delay: the numbers cable_group_critical gives group by group (tested)
        idx = [i for members in groups.values() for i in members]
        gid = [g for g, members in enumerate(groups.values()) for _ in members]
        got = cable_critical_stiffness_batch([devices[i] for i in idx], b[idx], groups=gid)
        kcr[idx], ang[idx], bmax[idx] = got.critical_stiffness, got.crossover_angle, got.max_stable_damping
        return BatchCritical(kcr, ang, bmax, scanned)
    for members in groups.values():
        delays = np.array([devices[i].delay for i in members])
        k, a, bm = fn(devices[members[0]], delays, b[members])
        kcr[members], ang[members], bmax[members] = k, a, bm
    return BatchCritical(kcr, ang, bmax, scanned)
