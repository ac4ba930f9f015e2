"""Exact K_cr(B) and B_max of many damped cable devices at once: the compiled cable brackets over rows (issue 32).

``cable_critical_stiffness_batch(devices, damping)`` gives, for each device and its virtual damping B, what
optim.stability.margins.critical_stiffness(device, B, b_max=max_stable_damping(device)) gives (its K_cr, binding
crossover and B_max, to the bit, and the same ``path``), for the robust box searches (optim.robust.batch) and the
studies.  Each device is sampled and factored once (optim.stability.margins.loop_plant, cable_loop: cached with
the plant; ≈ 0.3 ms for a device not seen before, most of a row's cost; devices that differ only in their whole
delay share it: a study's delay axis), then one compiled call
(optim.stability.cable_kernel.batch_rows) solves every row's damper-only loop (β_max) and K loop (K_cr at β) by
the cable brackets, ≈ 10–30 µs a row.

A row is handed to margins.critical_stiffness itself, device by device, wherever the brackets do not answer it
alone: the factored loop is not trusted (cable_loop None: an undamped cable, a factor within 1e3 of its own error
of the unit circle), the pieces do not resolve (or an answer beside a factor near the circle is conditioned past
cable_loop.MAX_NEAR_ERROR), B > 0 with no crossover found, B within NEAR_B_MAX of B_max (the bounded scan's
band), B above half of B_max (where K_cr may be a cancellation that the 40-digit re-solve settles:
optim.stability.near_b_max) or a mode within NEAR_LOSSLESS_GAP of the circle.  Those rows say their path
(``"bounded-scan"``, ``"scan"``) as margins does, and ``handed_off`` counts them.  Rigid devices are not taken here
(optim.stability.fast_batch); a device without a cable raises.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import cast

import numpy as np

from models.device import Device, with_delay
from models.discretize import StateSpaceZOH, split_delay
from models.plants import stiffness_loop_plant
from optim.errors import InputError
from optim.stability.cable_kernel import batch_rows
from optim.stability.cable_loop import CableLoop, cable_loop, with_whole_delay
from optim.stability.crossovers import theta_min
from optim.stability.margins import (
    NEAR_B_MAX,
    critical_stiffness,
    loop_plant,
    max_stable_damping,
)
from optim.stability.undamped_cable import NEAR_LOSSLESS_GAP, is_undamped_cable, mode_gap

__all__ = ["CableBatch", "cable_critical_stiffness_batch", "cable_critical_stiffness_grouped"]


@dataclass(frozen=True)
class CableBatch:
    """Per device (the order given): K_cr, its crossover and B_max, as margins.critical_stiffness answers them."""

    critical_stiffness: np.ndarray
    """K_cr [N/m]; 0 when B ≥ B_max (or no damping at all), inf when every K > 0 is stable."""
    crossover_angle: np.ndarray
    """ωT [rad/sample] of the binding crossover (ω = margins' crossover_frequency); NaN when K_cr is 0 or inf."""
    max_stable_damping: np.ndarray
    """B_max [N·s/m] of each device (computed for every row, B = 0 included)."""
    path: tuple[str, ...]
    """Each row's path: "fast" (the compiled brackets), else margins' own ("bounded-scan", "scan")."""
    handed_off: int
    """Rows answered by margins.critical_stiffness device by device (module docstring)."""


def _as_vector(damping: float | np.ndarray, n: int) -> np.ndarray:
    b = np.broadcast_to(np.asarray(damping, dtype=float), (n,)).astype(float)
    if not np.all(np.isfinite(b) & (b >= 0.0)):
        raise InputError("damping", "virtual damping B must be finite and ≥ 0")
    return b


def cable_critical_stiffness_batch(devices: Sequence[Device], damping: float | np.ndarray = 0.0,
                                   groups: Sequence[int] | None = None) -> CableBatch:
    """K_cr(B), θ and B_max of every cable device in ``devices`` at its virtual damping (a scalar, or one per device)
    [N·s/m]: margins.critical_stiffness's answers, rows solved together by the compiled cable brackets where they
    answer alone, the rest handed to margins device by device (module docstring).

    ``groups`` (optional, one int per device): devices with the same number are the caller's promise that they are
    equal but for their delay (a study chunk's cable × delay grid, optim.studies.cable_chunks).  Then the plant is
    sampled once per group and fractional part of the delay, not once per device: the rows' numbers are the same
    (the factored loop of a plant depends on its fractional delay alone; the whole samples d are the loop's numbers
    s and d), only the per-device sampling is saved.  (:func:`cable_critical_stiffness_grouped` with each group's
    first device as its base and each device's delay.)"""
    n = len(devices)
    if groups is not None and len(groups) != n:
        raise InputError("groups", f"one group number per device: {len(groups)} for {n} devices")
    if groups is None:
        bases, row_group = list(devices), np.arange(n, dtype=np.int64)
    else:
        first: dict[int, int] = {}
        row_group = np.array([first.setdefault(g, len(first)) for g in groups], dtype=np.int64)
        bases = []
        for i, g in enumerate(row_group.tolist()):
            if g == len(bases):      # groups are numbered in the order they first appear
                bases.append(devices[i])
    delays = np.array([dev.delay for dev in devices], dtype=float)
    return cable_critical_stiffness_grouped(bases, row_group, delays, damping, devices=devices)


def cable_critical_stiffness_grouped(bases: Sequence[Device], group: np.ndarray, delays: np.ndarray,
                                     damping: float | np.ndarray = 0.0,
                                     devices: Sequence[Device] | None = None,
                                     cache_plants: bool = True) -> CableBatch:
    """:func:`cable_critical_stiffness_batch` of the rows ``models.device.with_delay(bases[group[i]], delays[i])``
    without a Device per row (issue 32: a study chunk's cable × delay grid): each row's numbers (d = t_d/T, δ, the
    scales) are read from its base's fields by the same float operations as the Device's properties, elementwise;
    a base's plant is sampled once per fractional part of its rows' delays (the device of its first such row), and
    a row handed to margins gets its Device then (``devices[i]`` when the caller holds them).  Every base must have
    a cable; a base's own delay is not read.

    ``cache_plants=False`` samples the plants by models.plants.stiffness_loop_plant instead of margins.loop_plant
    (the same plant; loop_plant keeps the last 4096 with their factored loops): a study's chunks never ask for a
    group's plant again, and a worker that held 4096 of them (≈ 90k objects) spent ≈ 3-5 µs a point more in the
    garbage collector's full passes (issue 32, docs/profile_cable_studies.md)."""
    n = len(group)
    bvec = _as_vector(damping, n)
    g = np.asarray(group, dtype=np.int64)
    dl = np.asarray(delays, dtype=float)
    kcr = np.full(n, math.nan)
    ang = np.full(n, math.nan)
    bmax = np.full(n, math.nan)
    paths = ["fast"] * n

    def device(i: int) -> Device:
        return devices[i] if devices is not None else with_delay(bases[int(g[i])], float(dl[i]))

    rigid = [j for j, base in enumerate(bases) if base.cable is None]
    if rigid:
        first = np.flatnonzero(np.isin(g, rigid))
        i = int(first[0]) if len(first) else rigid[0]
        raise InputError("devices", f"device {i} has no cable: rigid devices take optim.stability.fast_batch")
    # each base's numbers (the Device properties' own float operations), then each row's by its base
    st = np.array([b.sample_time for b in bases], dtype=float)
    bdamp = np.array([b.damping for b in bases], dtype=float)
    undamped = np.array([is_undamped_cable(b) for b in bases], dtype=bool)
    ds_all = dl / st[g]                                   # Device.delay_samples: delay / sample_time
    live = ~undamped[g] & ~(bdamp[g] + bvec <= 0.0)       # the rows the brackets may take
    # whole samples d and fractional part f of each row's delay (split_delay, once per distinct value)
    uds, inv = np.unique(ds_all[live], return_inverse=True)
    split = [split_delay(v) for v in uds.tolist()]
    d_live = np.array([s[0] for s in split], dtype=np.int64)[inv]
    f_live = np.array([s[1] for s in split], dtype=float)[inv]
    live_rows = np.flatnonzero(live)
    # one sampled plant per (base, fractional delay): a "unit"; its key (plant matrices and f) shared by equal plants
    fu, finv = np.unique(f_live, return_inverse=True)
    unit_code = g[live_rows] * max(1, len(fu)) + finv
    _, unit_first, unit_of = np.unique(unit_code, return_index=True, return_inverse=True)
    shared: dict[tuple, CableLoop | None] = {}
    plants: dict[tuple, StateSpaceZOH] = {}
    sample = loop_plant if cache_plants else stiffness_loop_plant
    loops: list[tuple] = []
    loop_of: dict[tuple, int] = {}
    unit_key: list[tuple] = [()] * len(unit_first)
    unit_li = np.full(len(unit_first), -1, dtype=np.int64)
    for u in np.argsort(unit_first, kind="stable").tolist():      # in the rows' order (the caches' order)
        plant = cast(StateSpaceZOH, sample(device(int(live_rows[unit_first[u]]))))   # a cable device's plant
        key = _plant_key(plant)
        if key not in shared:
            loop = cable_loop(plant)
            plants[key] = plant
            shared[key] = loop if loop is not None and mode_gap(plant) >= NEAR_LOSSLESS_GAP else None
        unit_key[u] = key
        got = shared[key]
        if got is not None:
            li = loop_of.get(key)
            if li is None:
                li = loop_of[key] = len(loops)
                loops.append(got.arrays)
            unit_li[u] = li
    # each live row's plant (a handed-off row takes it from there) and, for the rows the brackets take, their loop
    row_li_live = unit_li[unit_of] if len(unit_of) else np.zeros(0, dtype=np.int64)
    taken = row_li_live >= 0
    idx = live_rows[taken]
    handoff = np.flatnonzero(~live).tolist() + live_rows[~taken].tolist()

    def row_plant(i: int) -> tuple[tuple, int] | None:
        """(plant key, whole delay d) of a live row, None for a row the brackets never sampled."""
        k = int(np.searchsorted(live_rows, i))
        if k == len(live_rows) or live_rows[k] != i:
            return None
        return unit_key[int(unit_of[k])], int(d_live[k])

    if len(idx):
        loop_idx = row_li_live[taken]
        d_rows = d_live[taken]
        # rows of one sampled plant at one whole delay (at several B) solve its damper-only loop once: the first
        # such row's position
        pair = loop_idx * (int(d_rows.max()) + 1) + d_rows
        _, pair_first, pair_of = np.unique(pair, return_index=True, return_inverse=True)
        same = pair_first[pair_of].astype(np.int64)
        gi = g[idx]
        mass = np.array([b.mass for b in bases], dtype=float)
        t = st[gi]
        bs = (mass / st)[gi]                              # Device.damping_scale: m/T
        ks = (mass / st**2)[gi]                           # Device.stiffness_scale: m/T²
        delta = (bdamp * st / mass)[gi]                   # Device.delta: bT/m
        ds = ds_all[idx]
        betas = bvec[idx] / bs
        # crossovers.theta_min's array form: the scalar form's bits, elementwise (as margins._theta_min's δ + β)
        lo_b = np.atleast_1d(theta_min(delta, ds))
        lo_k = np.atleast_1d(theta_min(delta + betas, ds))
        fr, fc, modal, nums, splits, f_off, s_off = _stack(loops)
        st_b, th_b, al_b, st_k, th_k, al_k = batch_rows(fr, fc, modal, _row_nums(nums, loop_idx, d_rows), splits,
                                                        f_off, s_off, loop_idx, betas, lo_b, lo_k, same)
        # each row's case, elementwise (the same float operations as margins' scalar ones, so the same bits)
        b = bvec[idx]
        ok_b = st_b == 2
        bm = al_b * bs
        dead = ok_b & (b > 0.0) & (b >= bm)
        near = ok_b & ~dead & (b > 0.0) & ((b >= bm * (1.0 - NEAR_B_MAX)) | (b > 0.5 * bm) | (st_k != 2))
        solved = ok_b & ~dead & ~near & (st_k != 0)
        # B_max from the brackets where they gave it (the value margins.max_stable_damping's own brackets give);
        # the rows near B_max or without a crossover are handed to margins with it, the rest to margins whole
        bmax[idx[ok_b]] = bm[ok_b]
        kcr[idx[dead]], ang[idx[dead]] = 0.0, math.nan
        inf = solved & (st_k == 1)
        fin = solved & (st_k == 2)
        kcr[idx[inf]] = math.inf
        kcr[idx[fin]] = al_k[fin] * ks[fin]
        ang[idx[fin]] = th_k[fin] / t[fin] * t[fin]          # ω·T as margins' ω = θ/T gives it
        handoff += idx[~(dead | solved)].tolist()
    for i in sorted(handoff):
        dev, b_i = device(i), float(bvec[i])
        bm_i = float(bmax[i]) if math.isfinite(bmax[i]) else max_stable_damping(dev)
        known_plant = row_plant(i)
        res = critical_stiffness(dev, b_i, b_max=bm_i if b_i > 0.0 else None,
                                 plant=None if known_plant is None else _at_whole_delay(plants[known_plant[0]],
                                                                                         known_plant[1]))
        kcr[i] = res.critical_stiffness
        w = res.crossover_frequency
        ang[i] = math.nan if w is None else w * dev.sample_time
        bmax[i] = bm_i
        paths[i] = res.path
    return CableBatch(kcr, ang, bmax, tuple(paths), len(handoff))


def _plant_key(plant) -> tuple:
    """What a sampled cable plant's factored loop depends on: its matrices and fractional delay (not d)."""
    return (plant.a.tobytes(), plant.b.tobytes(), plant.c.tobytes(), plant.f)


#: what a sampled cable plant keeps in its cache that depends on its matrices and fractional delay alone, not on d
#: (models.discretize.StateSpaceZOH: accurate_matrices, modal_form, pole_angles, zero_hints; undamped_cable.mode_gap)
_WHOLE_DELAY_FREE = ("m", "modal", "angles", "mode_gap", "zeros")


def _at_whole_delay(plant: StateSpaceZOH, d: int) -> StateSpaceZOH:
    """The sampled plant of the same device with d whole samples of delay: what loop_plant gives for it (a, b, c, f and
    the zeros are the device's without its delay, d its whole samples), with the cached parts that do not depend on d
    (_WHOLE_DELAY_FREE) taken along, and its factored loop moved to d, so a handed-off row does not sample, diagonalise
    and factor its plant again."""
    if plant.d == d:
        return plant
    new = dataclasses.replace(plant, d=d, _cache={})
    new._cache.update({k: plant._cache[k] for k in _WHOLE_DELAY_FREE if k in plant._cache})
    loop = plant._cache.get("cable_loop")
    if loop is not None:          # its factored loop at d (cable_loop.with_whole_delay: what cable_loop would build)
        new._cache["cable_loop"] = with_whole_delay(loop, d)
    return new


def _row_nums(nums: np.ndarray, loop: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Each row's numbers (cable_loop.loop_arrays): its loop's (``nums[loop]``) with d whole samples of delay, where
    only s = d + m + 1 and d differ (the modal form, its factors and splits depend on the fractional part alone).
    s − d (= m + 1) and d are small integers: each float is exact, the bits of float(d + m + 1) and float(d)."""
    out = nums[loop]
    out[:, 0] = d + (out[:, 0] - out[:, 3])          # N_S: d + m + 1
    out[:, 3] = d                                     # N_D
    return out


def _stack(arrays) -> tuple[np.ndarray, ...]:
    """The loops' arrays (cable_loop.loop_arrays) stacked for the kernel: factors' rows and splits concatenated with
    their offsets; the modal forms and numbers one row each."""
    frs, fcs, modals, nums, splits = zip(*arrays)
    f_off = np.zeros(len(arrays) + 1, dtype=np.int64)
    f_off[1:] = np.cumsum([x.shape[0] for x in frs])
    s_off = np.zeros(len(arrays) + 1, dtype=np.int64)
    s_off[1:] = np.cumsum([x.shape[0] for x in splits])
    return (np.concatenate(frs), np.concatenate(fcs), np.stack(modals), np.stack(nums),
            np.concatenate(splits) if s_off[-1] else np.zeros(0), f_off, s_off)
