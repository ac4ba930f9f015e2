"""The ``critical_stiffness`` study problem: K_cr(B) of a whole chunk of points at once (issue 8).

The ``stability`` problem (optim.studies.stability_study) adds passivity, Q and the rigid comparison to every
point.  A sweep that only needs the stability boundary gets it here from
``optim.robust.batch.batch_critical_stiffness``, which scans every device of the chunk in the same
numpy arrays (grouped by plant structure inside it: rigid, cable, …), except damped cables: their points are
grouped by everything but the delay and each group goes to one function (optim.studies.cable_chunks, the swap
point for a batch cable K_cr).  Same mathematics as
``optim.stability.margins.critical_stiffness`` (every crossover bracketed and refined to double precision),
different arithmetic order: the values agree to ~1e-15 relative, not bit for bit.

Per point: ``critical_stiffness`` [N/m], ``crossover_frequency`` [rad/s], ``max_stable_damping``
[N·s/m], ``linear_estimate`` (eq. 10) [N/m], ``reason`` and, for a wall stiffness K,
``gain_margin_db`` and ``stable``.  Non-finite values are None with the reason; a NaN (numerics
out of range) fails its point, never the chunk.
"""

from __future__ import annotations

import math
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from models.device import Device
from optim.stability.margins import gain_margin_db, linear_estimate
from optim.studies.cable_chunks import critical_arrays, is_grouped_cable

__all__ = ["evaluate_batch", "evaluate_one", "by_delay_class", "one_point", "row", "finite_or_none"]

_NO_DAMPING = ("no physical or virtual damping: no positive stiffness is stable "
               "(linear condition α < 2(δ+β)/(1+2d) with δ = β = 0)")
_NO_CROSSOVER = "no phase crossover: every positive stiffness is stable"


def finite_or_none(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def row(dev: Device, req: Mapping[str, Any], kcr: float, angle: float, bmax: float) -> tuple[dict | None, str | None]:
    b = float(req.get("damping") or 0.0)
    k = req.get("stiffness")
    if math.isnan(kcr) or math.isnan(bmax):
        # 0 and inf are answers (no K / every K stable); NaN is an arithmetic failure: the point fails
        return None, "device: the parameters are outside the numerically representable range (K_cr is NaN)"
    reason = None
    if kcr == 0.0:
        reason = (_NO_DAMPING if dev.damping + b <= 0.0 else
                  f"virtual damping B = {b:.6g} N·s/m is at or above the largest stable virtual damping "
                  f"B_max = {bmax:.6g} N·s/m for this delay: no positive stiffness is stable")
    elif math.isinf(kcr):
        reason = _NO_CROSSOVER
    out: dict[str, Any] = {
        "critical_stiffness": finite_or_none(kcr),
        "crossover_frequency": finite_or_none(angle / dev.sample_time) if kcr > 0 and math.isfinite(kcr) else None,
        "max_stable_damping": finite_or_none(bmax),
        "linear_estimate": finite_or_none(linear_estimate(dev, b)),
    }
    if k is not None:
        # as optim.stability.analysis: stable iff K < K_cr; the margin only where K_cr is a positive finite number
        out["stable"] = bool(k < kcr)
        out["gain_margin_db"] = gain_margin_db(kcr, float(k)) if 0.0 < kcr < math.inf else None
    out["reason"] = reason
    return out, None


def evaluate_batch(devices: Sequence[Device], requirements: Sequence[Mapping[str, Any]]
                   ) -> list[tuple[dict | None, str | None]]:
    """(results, None) or (None, reason) for each (device, requirements) pair, in order.

    The requirements must already be valid (optim.studies.problems checks each point's).  When the batch
    raises, it is split in halves down to the point that raises, so that only that point fails.
    """
    from optim.studies.rendered_study import split_rendered
    return split_rendered("critical_stiffness", devices, requirements,
                          lambda d, r: by_delay_class(d, r, _evaluate_same_class))


Batch = Callable[[Sequence[Device], Sequence[Mapping[str, Any]]], list[tuple[dict | None, str | None]]]


def by_delay_class(devices: Sequence[Device], requirements: Sequence[Mapping[str, Any]], same_class: Batch
                   ) -> list[tuple[dict | None, str | None]]:
    """Run ``same_class`` on the points of each delay class, bisecting a batch that raises down to its point.

    Rows of one batch share a grid length set by the longest delay: points of very different delays are
    scanned in separate batches (delay classes a factor 2 apart) so that one long delay does not make
    every row of the chunk long."""
    if not devices:
        return []
    classes: dict[int, list[int]] = {}
    for i, dev in enumerate(devices):
        # rigid devices take the fast exact path (no grid): one batch whatever their delays; the few rows it
        # leaves to the scan get row-own grids (optim.robust.batch._grids), so a row never depends on the batch
        # damped cables: one class, grouped inside by everything but the delay (optim.studies.cable_chunks)
        key = -1 if dev.cable is None else -2 if is_grouped_cable(dev) else int(math.log2(1.0 + dev.delay_samples))
        classes.setdefault(key, []).append(i)
    out: list[tuple[dict | None, str | None]] = [(None, None)] * len(devices)
    for idx in classes.values():
        for i, r in zip(idx, _bisecting(same_class, [devices[i] for i in idx], [requirements[i] for i in idx])):
            out[i] = r
    return out


def _bisecting(same_class: Batch, devices: Sequence[Device], requirements: Sequence[Mapping[str, Any]]
               ) -> list[tuple[dict | None, str | None]]:
    try:
        # inf/nan inside the scan are expected (no crossover, 1/0 at a pole); NaN results are caught per point
        with np.errstate(all="ignore"):
            return same_class(devices, requirements)
    except Exception as exc:  # noqa: BLE001 - recorded against the point that raises, never the whole chunk
        if len(devices) == 1:
            return [(None, f"{type(exc).__name__}: {exc}")]
        half = len(devices) // 2
        return (_bisecting(same_class, devices[:half], requirements[:half])
                + _bisecting(same_class, devices[half:], requirements[half:]))


def _evaluate_same_class(devices: Sequence[Device], requirements: Sequence[Mapping[str, Any]]
                         ) -> list[tuple[dict | None, str | None]]:
    b = np.array([float(r.get("damping") or 0.0) for r in requirements])
    res = critical_arrays(devices, b)
    return [row(dev, req, float(k), float(a), float(bm))
            for dev, req, k, a, bm in zip(devices, requirements, res.critical_stiffness, res.crossover_angle,
                                          res.max_stable_damping)]


def evaluate_one(device: Device, requirements: Mapping[str, Any]) -> dict[str, Any]:
    """One point (``evaluate_point``): a batch of one; raises ValueError with the reason when it fails."""
    return one_point(evaluate_batch, device, requirements)


def one_point(batch: Batch, device: Device, requirements: Mapping[str, Any]) -> dict[str, Any]:
    """``batch`` on one point: its results, or ValueError with the reason the point failed."""
    result, error = batch([device], [requirements])[0]
    if error is not None:
        raise ValueError(error)
    return result
