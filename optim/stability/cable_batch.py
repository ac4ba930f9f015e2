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

import numpy as np

from models.device import Device
from models.discretize import StateSpaceZOH, split_delay
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

__all__ = ["CableBatch", "cable_critical_stiffness_batch"]


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
    s and d), only the per-device sampling is saved."""
    n = len(devices)
    bvec = _as_vector(damping, n)
    kcr = np.full(n, math.nan)
    ang = np.full(n, math.nan)
    bmax = np.full(n, math.nan)
    paths = ["fast"] * n
    rows: list[int] = []
    # each factored loop's arrays once (the kernel finds a row's by its index in ``loops``), and each row's index and
    # whole delay d (its numbers s and d: the loop's own moved to d, _row_nums)
    loops: list[tuple] = []
    loop_of: dict[tuple, int] = {}
    row_loop: list[int] = []
    row_d: list[int] = []
    # devices that differ only in their whole delay share the factored loop (its numbers s and d aside)
    shared: dict[tuple, CableLoop | None] = {}
    # rows of one sampled plant (at several B) solve its damper-only loop once: the first such row's index
    seen: dict[tuple, int] = {}
    same: list[int] = []
    # (group, fractional delay) -> the key of its sampled plant (with ``groups``: one plant sampled per pair)
    sampled: dict[tuple[int, float], tuple] = {}
    # the sampled plant of each key, and each row's (key, whole delay d): a handed-off row takes its plant from there
    plants: dict[tuple, StateSpaceZOH] = {}
    row_plant: dict[int, tuple[tuple, int]] = {}
    if groups is not None and len(groups) != n:
        raise InputError("groups", f"one group number per device: {len(groups)} for {n} devices")
    blist = bvec.tolist()
    for i, dev in enumerate(devices):
        if dev.cable is None:
            raise InputError("devices", f"device {i} has no cable: rigid devices take optim.stability.fast_batch")
        if is_undamped_cable(dev) or dev.damping + blist[i] <= 0.0:
            continue
        fresh = None
        if groups is None:
            fresh = loop_plant(dev)
            d, key = fresh.d, _plant_key(fresh)
        else:
            d, f = split_delay(dev.delay_samples)      # as stiffness_loop_plant splits it
            known = sampled.get((groups[i], f))
            if known is None:
                fresh = loop_plant(dev)
                known = sampled[(groups[i], f)] = _plant_key(fresh)
            key = known
        if key not in shared:
            plant = fresh if fresh is not None else loop_plant(dev)
            loop = cable_loop(plant)
            plants[key] = plant
            shared[key] = loop if loop is not None and mode_gap(plant) >= NEAR_LOSSLESS_GAP else None
        row_plant[i] = (key, d)
        got = shared[key]
        if got is None:
            continue
        li = loop_of.get(key)
        if li is None:
            li = loop_of[key] = len(loops)
            loops.append(got.arrays)
        same.append(seen.setdefault((key, d), len(rows)))
        rows.append(i)
        row_loop.append(li)
        row_d.append(d)
    taken = set(rows)
    handoff = [i for i in range(n) if i not in taken]
    if rows:
        idx = np.array(rows)
        devs = [devices[i] for i in rows]
        bs = np.array([d.damping_scale for d in devs])
        ks = np.array([d.stiffness_scale for d in devs])
        delta = np.array([d.delta for d in devs])
        ds = np.array([d.delay_samples for d in devs])
        betas = bvec[idx] / bs
        # crossovers.theta_min's array form: the scalar form's bits, elementwise (as margins._theta_min's δ + β)
        lo_b = np.atleast_1d(theta_min(delta, ds))
        lo_k = np.atleast_1d(theta_min(delta + betas, ds))
        fr, fc, modal, nums, splits, f_off, s_off = _stack(loops)
        loop_idx = np.array(row_loop, dtype=np.int64)
        st_b, th_b, al_b, st_k, th_k, al_k = batch_rows(fr, fc, modal, _row_nums(nums, loop_idx, np.array(row_d)),
                                                        splits, f_off, s_off, loop_idx, betas, lo_b, lo_k,
                                                        np.array(same, dtype=np.int64))
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
        t = np.array([d.sample_time for d in devs])
        kcr[idx[fin]] = al_k[fin] * ks[fin]
        ang[idx[fin]] = th_k[fin] / t[fin] * t[fin]          # ω·T as margins' ω = θ/T gives it
        handoff += idx[~(dead | solved)].tolist()
    for i in sorted(handoff):
        dev, b = devices[i], float(bvec[i])
        bm = bmax[i] if math.isfinite(bmax[i]) else max_stable_damping(dev)
        known_plant = row_plant.get(i)
        res = critical_stiffness(dev, b, b_max=bm if b > 0.0 else None,
                                 plant=None if known_plant is None else _at_whole_delay(plants[known_plant[0]],
                                                                                         known_plant[1]))
        kcr[i] = res.critical_stiffness
        w = res.crossover_frequency
        ang[i] = math.nan if w is None else w * dev.sample_time
        bmax[i] = bm
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
