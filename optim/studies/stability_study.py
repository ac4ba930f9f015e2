"""The ``stability`` study problem on a whole chunk at once (issue 8: batch paths may vectorise).

Per point the same quantities as the exact rung of ``optim.stability.analysis.analyse_stability`` for the
wall {stiffness?, damping?}: K_cr(B) and its crossover, B_max, the margin and stability of K, the
passivity of (K, B) with the loop delay (ARCHITECTURE.md form, fractional delay rounded up), eq. 10
and its error, and for a cable device the Q criterion (eq. 22) and the rigid model's K_cr.  Each
computed for the chunk in numpy arrays: K_cr and B_max by ``optim.robust.batch.batch_critical_stiffness``
(the rigid comparison too), passivity by ``optim.stability.passivity.batch_required_damping``.  Same mathematics
as the one-point analysis, different arithmetic order: values agree to ~1e-13 relative, not bit for bit
(``tests/optim/studies/test_stability_study.py`` holds them against ``analyse_stability``).

Differences from the one-point analysis: ``max_stable_damping`` is given at B = 0 too, and there is no
count of crossovers (the batch scan keeps the binding one).  A point evaluated alone (``evaluate_one``)
is a batch of one, so a study's rows never depend on which path ran them.
"""

from __future__ import annotations

import math
from typing import Any, Mapping, Sequence

import numpy as np

from models.device import Device
from models.plants import Q_criterion
from optim.robust.batch import rigid_critical_stiffness
from optim.stability.analysis import EXACT_REL_ERROR, MODE_MATTERS_RTOL
from optim.stability.passivity import batch_required_damping, passivity_samples
from optim.studies.cable_chunks import critical_arrays
from optim.studies.critical_study import by_delay_class, finite_or_none, one_point, row

__all__ = ["evaluate_batch", "evaluate_one"]


def evaluate_batch(devices: Sequence[Device], requirements: Sequence[Mapping[str, Any]]
                   ) -> list[tuple[dict | None, str | None]]:
    """(results, None) or (None, reason) per (device, requirements), in order; requirements already valid (a point
    with a ``controller``: optim.studies.rendered_study)."""
    from optim.studies.rendered_study import split_rendered
    return split_rendered("stability", devices, requirements, lambda d, r: by_delay_class(d, r, _same_class))


def evaluate_one(device: Device, requirements: Mapping[str, Any]) -> dict[str, Any]:
    """One point: a batch of one; raises ValueError with the reason when it fails."""
    return one_point(evaluate_batch, device, requirements)


def _same_class(devices: Sequence[Device], requirements: Sequence[Mapping[str, Any]]
                ) -> list[tuple[dict | None, str | None]]:
    n = len(devices)
    b = np.array([float(r.get("damping") or 0.0) for r in requirements])
    res = critical_arrays(devices, b)
    rigid = np.full(n, np.nan)
    cable = [i for i, d in enumerate(devices) if d.cable is not None]
    if cable:
        # the rigid model's K_cr from arrays (m, b, T, t_d: all it depends on), no rigid Device per point; the rows
        # the fast path leaves open get their rigid Devices (rigid_critical_stiffness: batch_critical_stiffness's
        # numbers bit for bit)
        cd = [devices[i] for i in cable]
        rigid[cable] = rigid_critical_stiffness(
            np.array([d.mass for d in cd]), np.array([d.damping for d in cd]), np.array([d.sample_time for d in cd]),
            np.array([d.delay for d in cd]), b[cable], lambda rows: [cd[r].rigid() for r in rows]).critical_stiffness
    required = np.full(n, np.nan)
    with_k = [i for i, r in enumerate(requirements) if r.get("stiffness") is not None]
    d_used = {i: passivity_samples(devices[i]) for i in with_k}
    for d in sorted({v[0] for v in d_used.values()}):
        idx = [i for i in with_k if d_used[i][0] == d]
        half_tk = np.array([float(requirements[i]["stiffness"]) * devices[i].sample_time / 2 for i in idx])
        # each row of batch_required_damping is its own computation: the distinct (K·T/2, B) pairs once (a cable grid
        # repeats one wall over every cable)
        pairs, inverse = np.unique(np.column_stack([half_tk, b[idx]]), axis=0, return_inverse=True)
        required[idx] = batch_required_damping(d, pairs[:, 0], pairs[:, 1])[0][inverse.reshape(-1)]
    out = []
    for i, (dev, req) in enumerate(zip(devices, requirements)):
        base, error = row(dev, req, float(res.critical_stiffness[i]), float(res.crossover_angle[i]),
                          float(res.max_stable_damping[i]))
        if error is not None:
            out.append((None, error))
            continue
        out.append((_full(dev, req, base, float(res.critical_stiffness[i]), float(rigid[i]), float(required[i]),
                          d_used.get(i)), None))
    return out


def _full(dev: Device, req: Mapping[str, Any], base: dict, kcr: float, rigid_k: float, required: float,
          d_used: tuple[int, bool] | None) -> dict[str, Any]:
    k = req.get("stiffness")
    lin = base["linear_estimate"]
    q = mode = rigid_out = None
    if dev.cable is not None:
        q = Q_criterion(dev)
        rigid_out = finite_or_none(rigid_k)
        if math.isfinite(kcr) and rigid_k and math.isfinite(rigid_k):
            mode = abs(kcr / rigid_k - 1) > MODE_MATTERS_RTOL
    return {
        "critical_stiffness": base["critical_stiffness"],
        "crossover_frequency": base["crossover_frequency"],
        "damping": float(req.get("damping") or 0.0),
        "stiffness": None if k is None else float(k),
        "gain_margin_db": base.get("gain_margin_db"),
        "stable": base.get("stable"),
        "passive": None if k is None else bool(dev.damping > required),
        "passivity_required_damping": None if k is None else required,
        "passivity_conservative": False if k is None else d_used[1],
        "linear_estimate": lin,
        "linear_error": abs(lin / kcr - 1) if lin is not None and 0.0 < kcr < math.inf else None,
        "max_stable_damping": base["max_stable_damping"],
        "q_criterion": q,
        "mode_matters": mode,
        "rigid_critical_stiffness": rigid_out,
        "error_estimate": EXACT_REL_ERROR,
        "reason": base["reason"],
    }
