"""The ``critical_stiffness`` problem on a chunk of damped cable points as columns (issue 32).

A cable study (e.g. the lhifam preset over device.cable.stiffness × device.delay × device.cable.damping) is evaluated
by the per-point path (optim.studies.problems.evaluate_chunk) as: one validated Device per set of the non-delay swept
values, copied with each point's delay; every damped cable of the chunk in one
optim.studies.cable_chunks.critical_arrays call; a row dict per point (critical_study.row) that the block then turns
back into columns.  This module validates the same Devices the same way (one per set of non-delay values, the same
rule for a copied delay) but holds each point as (its base device, its delay) without a copy per point, answers the
chunk by optim.studies.cable_chunks.grouped_arrays (critical_arrays' numbers for those Devices, issue 32), and writes
the results straight as columns (optim.studies.columns.critical_columns: the same floating-point operations as
critical_study.row, elementwise), so a point's results are bit for bit the per-point path's
(tests/service/test_studies_blocks.py holds both paths against each other on cable grids).

Left to the per-point path (not handled): a point whose device does not validate, whose swept wall value breaks the
stability problem's rules, or which is not a damped cable (an undamped cable's scan depends on its delay class:
optim.studies.critical_study.by_delay_class).  A chunk the columns cannot take at all gives None (another problem,
a swept path outside the device and the wall, a base that is not a cable, or a critical_arrays call that raises:
the per-point path bisects down to the point that raises).
"""

from __future__ import annotations

import math
from typing import Any, Mapping, Sequence

import numpy as np

from models.device import Device
from optim.studies.cable_chunks import grouped_arrays, is_grouped_cable

__all__ = ["evaluate_cable_columns", "CABLE_COLUMN_REQUIREMENTS"]

#: swept requirement paths (besides any device.… path) the cable column path takes
CABLE_COLUMN_REQUIREMENTS = ("requirements.stiffness", "requirements.damping")


def _base_cable(device: Mapping[str, Any]) -> Device | None:
    try:
        base = Device.model_validate(dict(device))
    except ValueError:
        return None
    return base if base.cable is not None else None


def evaluate_cable_columns(problem: str, device: Mapping[str, Any], requirements: Mapping[str, Any],
                           axes: Sequence[tuple[str, str]], values: np.ndarray):
    """(handled, columns, errors) of the chunk's points as optim.studies.columns.evaluate_columns gives them, or None
    when the chunk is not for the cable column path (module docstring)."""
    from optim.studies.columns import critical_columns, scatter_columns
    from optim.studies.problems import point_builder, reuses_base

    if problem != "critical_stiffness":
        return None
    if any(not (p.startswith("device.") or p in CABLE_COLUMN_REQUIREMENTS) for p, _ in axes):
        return None
    if set(requirements) - {"stiffness", "damping"}:
        return None
    for key in ("stiffness", "damping"):
        v = requirements.get(key)
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v)):
            return None
    if _base_cable(device) is None:
        return None
    values = np.asarray(values, float).reshape(len(values), len(axes))
    n = values.shape[0]
    req: dict[str, np.ndarray | None] = {}
    for key in ("stiffness", "damping"):
        v = requirements.get(key)
        req[key] = None if v is None else np.full(n, float(v))
    for col, (path, _) in enumerate(axes):
        if path.startswith("requirements."):
            req[path.split(".", 1)[1]] = values[:, col].copy()
    ok = np.ones(n, bool)
    with np.errstate(all="ignore"):
        # optim.studies.problems' stability rules (the wall's K > 0, B ≥ 0, finite): a point that breaks one is left
        if req["stiffness"] is not None:
            ok &= np.isfinite(req["stiffness"]) & (req["stiffness"] > 0)
        if req["damping"] is not None:
            ok &= np.isfinite(req["damping"]) & (req["damping"] >= 0)
    # the points' devices as optim.studies.problems._evaluate_chunk_batch makes them: the first point of each set of
    # non-delay values validated whole (a "base"), the others that base with their delay (where the delay is a plain
    # finite number within the samples limit; any other point validated whole, its own base) — held as (base, delay)
    # without a Device per point (grouped_arrays: the Device's numbers read from its base, issue 32)
    build = point_builder(device, requirements, axes)
    delay_axis = next((j for j, (path, _) in enumerate(axes) if path == "device.delay"), None)
    others = [j for j in range(len(axes)) if j != delay_axis]
    by_rest: dict[tuple, int] = {}
    validate = Device.model_validate
    bases: list[Device] = []
    grouped: list[bool] = []
    limits: list[float] = []
    rows: list[int] = []
    base_of: list[int] = []
    delays: list[float] = []
    okl = ok.tolist()
    for i, vals in enumerate(values.tolist()):
        j: int | None = None
        if delay_axis is not None:
            delay = vals[delay_axis]
            rest = tuple([vals[k] for k in others])
            j = by_rest.get(rest)
            if j is not None and not reuses_base(delay, limits[j]):
                j = None
        if j is None:
            try:
                dev = validate(build(vals)[0])
            except ValueError:
                continue
            j = len(bases)
            bases.append(dev)
            grouped.append(is_grouped_cable(dev))
            limits.append(dev.sample_time)
            delay = dev.delay
            if delay_axis is not None:
                by_rest.setdefault(rest, j)
        if okl[i] and grouped[j]:
            rows.append(i)
            base_of.append(j)
            delays.append(delay)
    handled = np.zeros(n, bool)
    idx = np.array(rows, dtype=np.int64)
    handled[idx] = True
    b = req["damping"][idx] if req["damping"] is not None else np.zeros(len(idx))
    k = req["stiffness"][idx] if req["stiffness"] is not None else None
    used = sorted(set(base_of))                    # the bases of handled points (grouped_arrays takes those alone)
    renum = {j: u for u, j in enumerate(used)}
    of = np.array([renum[j] for j in base_of], dtype=np.int64)
    kept = [bases[j] for j in used]
    td = np.array(delays, dtype=float)
    try:
        with np.errstate(all="ignore"):
            res = grouped_arrays(kept, of, td, b)
    except Exception:  # noqa: BLE001 - the per-point path bisects down to the point that raises, and words it
        return None
    bp = np.array([d.damping for d in kept], dtype=float)[of]
    t = np.array([d.sample_time for d in kept], dtype=float)[of]
    sub_cols, sub_err = critical_columns(problem, None, bp, t, td, b, k, res)
    out, errors = scatter_columns(n, idx, sub_cols, sub_err)
    return handled, out, errors
